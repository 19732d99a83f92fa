#pragma once

#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace die_cushion_ident {

/// An output that cannot be written (a full disk, no permission, a missing directory): every tool exits
/// with the contract's code 4 on it.
class WriteError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// The suffix of a file being written: it takes its final name only when whole.
inline constexpr const char* kPartialSuffix = ".partial";

/// Closes `file` (written to `path`); throws WriteError when a write or the close failed.
void closeChecked(std::ofstream& file, const std::string& path);

/// A tool's output files, whole or absent (issues 28 and 45), for every tool (analyze_bag, analyze_trend,
/// simulate_bag, study_settings; scripts/report does the same in Python):
/// - each file is written under a temporary name in its own directory (`FINAL.partial`, from add());
/// - commit() flushes each to the disk (fsync) and renames them to their final names in the order they were
///   added, so that the file that says the run is complete (summary.yaml, trend.yaml, recommendation.txt)
///   comes last; any failure throws WriteError;
/// - a set that is not committed (an error, a full disk, an exception on the way) removes its temporary
///   files when destroyed; no final name is touched before commit(), so a previous run's files stay as they
///   were.
/// A run that exits through std::exit does not unwind: throw instead, and let main() choose the code.
class OutputFiles {
 public:
  OutputFiles() = default;
  OutputFiles(const OutputFiles&) = delete;
  OutputFiles& operator=(const OutputFiles&) = delete;
  ~OutputFiles();

  /// Adds `path` to the set; returns the temporary name to write it under (a previous one removed).
  std::string add(const std::string& path);
  /// Flushes every file to the disk and renames it to its final name, in the order added.
  void commit();
  /// The final paths, in the order added.
  const std::vector<std::string>& paths() const { return paths_; }

 private:
  std::vector<std::string> paths_;
  std::size_t renamed_ = 0;  // the first renamed_ paths carry their final names
};

/// `text` written to `path`, whole or not at all (a set of one file); throws WriteError.
void writeWholeFile(const std::string& path, const std::string& text);

}  // namespace die_cushion_ident
