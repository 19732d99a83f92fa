#pragma once

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// The command-line parser shared by the tools: each option is declared once with what it does, and every
/// tool gives the same errors in the same words ("--out needs a value", "unknown option --x", "--jobs needs a
/// whole number in [1, 256], got '2.5'"). Handlers may throw std::invalid_argument with a message of their
/// own; parse() returns it.
class ArgumentParser {
 public:
  using Handler = std::function<void(const std::string& value)>;

  /// A flag without a value.
  ArgumentParser& flag(const std::string& name, std::function<void()> on);
  /// An option that takes the next argument as its value.
  ArgumentParser& option(const std::string& name, Handler on);
  /// An option whose value must be a number in [low, high] (the whole argument; not NaN).
  ArgumentParser& number(const std::string& name, double low, double high, double* out);
  /// An option whose value must be a whole number in [low, high].
  ArgumentParser& wholeNumber(const std::string& name, long low, long high, int* out);
  /// What takes the arguments that are not options (at most `count` of them; `what` names them in errors).
  ArgumentParser& positional(const std::string& what, int count, Handler on);

  /// Parses argv[1..]; returns "" when every argument was understood, else what was wrong (one line).
  /// --help and -h are understood by every tool: helpRequested() is then true.
  std::string parse(int argc, const char* const* argv);
  bool helpRequested() const { return help_; }
  /// parse(), then what every tool does with its result: on --help the usage to stdout and exit 0; on a
  /// problem "TOOL: problem" and the usage to stderr and exit 2 (the contract's code for a bad command line).
  void parseOrExit(int argc, const char* const* argv, const std::string& tool, const std::string& usage);

 private:
  struct Option {
    bool takes_value = false;
    Handler on;
  };
  std::map<std::string, Option> options_;
  std::string positional_what_ = "argument";
  int positional_count_ = 0;
  Handler positional_;
  bool help_ = false;
};

}  // namespace die_cushion_ident
