#pragma once
// Runs the package's command-line tools from a test, with their exit status and everything they printed.
#include <sys/wait.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

namespace die_cushion_ident {
namespace testing {

struct CommandResult {
  int status;  ///< exit code; -1 when the command died by a signal
  std::string output;
};

/// Runs `command` in a shell, its stdout and stderr collected in `log_path`.
inline CommandResult runCommand(const std::string& command, const std::string& log_path) {
  const int raw = std::system((command + " > " + log_path + " 2>&1").c_str());
  std::ifstream in(log_path);
  return {WIFEXITED(raw) ? WEXITSTATUS(raw) : -1,
          std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>())};
}

}  // namespace testing
}  // namespace die_cushion_ident
