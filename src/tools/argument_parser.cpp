#include "argument_parser.h"

#include <cstdlib>
#include <iostream>
#include <stdexcept>

#include "command_line.h"
#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {

ArgumentParser& ArgumentParser::flag(const std::string& name, std::function<void()> on) {
  options_[name] = {false, [on](const std::string&) { on(); }};
  return *this;
}

ArgumentParser& ArgumentParser::option(const std::string& name, Handler on) {
  options_[name] = {true, std::move(on)};
  return *this;
}

ArgumentParser& ArgumentParser::number(const std::string& name, double low, double high, double* out) {
  return option(name, [=](const std::string& text) {
    const auto value = numberIn(text, low, high);
    if (!value) {
      throw std::invalid_argument(name + " needs a number in [" + formatted(FMT_STRING("{:g}"), low) + ", " +
                                  formatted(FMT_STRING("{:g}"), high) + "], got '" + text + "'");
    }
    *out = *value;
  });
}

ArgumentParser& ArgumentParser::wholeNumber(const std::string& name, long low, long high, int* out) {
  return option(name, [=](const std::string& text) {
    const auto value = wholeNumberIn(text, low, high);
    if (!value) {
      throw std::invalid_argument(name + " needs a whole number in [" + std::to_string(low) + ", " +
                                  std::to_string(high) + "], got '" + text + "'");
    }
    *out = static_cast<int>(*value);
  });
}

ArgumentParser& ArgumentParser::positional(const std::string& what, int count, Handler on) {
  positional_what_ = what;
  positional_count_ = count;
  positional_ = std::move(on);
  return *this;
}

std::string ArgumentParser::parse(int argc, const char* const* argv) {
  int positionals = 0;
  try {
    for (int i = 1; i < argc; ++i) {
      const std::string a = argv[i];
      if (a == "--help" || a == "-h") {
        help_ = true;
        return "";
      }
      const auto found = options_.find(a);
      if (found != options_.end()) {
        if (!found->second.takes_value) {
          found->second.on("");
        } else if (i + 1 >= argc) {
          return a + " needs a value";
        } else {
          found->second.on(argv[++i]);
        }
      } else if (a.size() > 1 && a[0] == '-') {
        return "unknown option " + a;
      } else if (positional_ && positionals < positional_count_) {
        ++positionals;
        positional_(a);
      } else {
        return "unexpected argument '" + a + "'" + (positional_count_ > 0 ? " (only " + std::to_string(positional_count_) +
                                                                                " " + positional_what_ + " expected)"
                                                                          : "");
      }
    }
  } catch (const std::invalid_argument& e) {
    return e.what();
  }
  return "";
}

void ArgumentParser::parseOrExit(int argc, const char* const* argv, const std::string& tool, const std::string& usage) {
  const std::string problem = parse(argc, argv);
  if (help_) {
    std::cout << usage;
    std::exit(0);
  }
  if (!problem.empty()) {
    std::cerr << tool << ": " << problem << "\n" << usage;
    std::exit(2);
  }
}

}  // namespace die_cushion_ident
