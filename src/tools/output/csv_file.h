#pragma once

#include <fstream>
#include <initializer_list>
#include <string>

namespace die_cushion_ident {

/// The one CSV writer of the tools (estimates.csv, model_comparison.csv, frequency_response.csv,
/// valve_fit.csv, proposals.csv, trend.csv, settings_study.csv): fields separated by commas as they are
/// added, a number written with a stated count of significant digits through std::to_chars (the text of
/// printf's %.Ng at a fraction of an ostream's cost, which matters for the hundreds of thousands of rows of
/// an hour's recording), and an empty field where a number could not be computed (never nan or inf: every
/// reader of the files takes an empty field for "missing"). A failed write or close throws WriteError
/// (output_files.h).
class CsvFile {
 public:
  /// Significant digits of a number unless a call says otherwise: more than the estimates' own accuracy.
  static constexpr int kDefaultDigits = 10;

  explicit CsvFile(std::string path);

  /// A header row of fixed column names, ended.
  void header(std::initializer_list<const char*> columns);
  /// A word or a column name, as it is (no comma or quote in it).
  CsvFile& text(const std::string& text);
  /// Text that may hold commas (a file path, an expression): in double quotes, a quote in it doubled.
  CsvFile& quoted(const std::string& text);
  /// `value` with `digits` significant digits (%.Ng); empty when not finite.
  CsvFile& number(double value, int digits = kDefaultDigits);
  CsvFile& integer(long long value);
  /// `value` with `decimals` digits after the point (%.Nf): time stamps; empty when not finite.
  CsvFile& fixed(double value, int decimals);
  /// Ends the row; the next field starts a new one.
  void endLine();
  /// Writes what is buffered and closes the file; throws WriteError when either failed.
  void close();

 private:
  static constexpr std::size_t kFlushSize = 1 << 16;
  void separate();
  void append(double value, bool fixed, int precision);
  void flush();

  std::string path_;
  std::ofstream file_;
  std::string buffer_;
  bool row_started_ = false;
};

}  // namespace die_cushion_ident
