#pragma once
// Runs the package's command-line tools from a test, with their exit status and everything they printed.
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

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

/// A test's folder for its recordings and analyses, of its own process: two checkouts' suites (or two runs of
/// one test) on one machine must not write into, or remove, each other's files. Removed when the process
/// exits, unless DCI_KEEP_WORK is set (to look at the recordings of a failure).
inline std::string workDirectory(const std::string& test) {
  static std::vector<std::string> folders;
  const std::string folder = "/tmp/die_cushion_ident_" + test + "_" + std::to_string(::getpid());
  if (folders.empty() && !std::getenv("DCI_KEEP_WORK")) {
    std::atexit([] {
      std::error_code ignored;
      for (const auto& f : folders) std::filesystem::remove_all(f, ignored);
    });
  }
  folders.push_back(folder);
  return folder;
}

}  // namespace testing
}  // namespace die_cushion_ident
