#include "output/csv_file.h"

#include <charconv>
#include <cmath>
#include <utility>

#include "output/output_files.h"

namespace die_cushion_ident {

CsvFile::CsvFile(std::string path) : path_(std::move(path)), file_(path_) {
  buffer_.reserve(kFlushSize + 256);
}

void CsvFile::separate() {
  if (row_started_) buffer_ += ',';
  row_started_ = true;
}

void CsvFile::header(std::initializer_list<const char*> columns) {
  for (const char* column : columns) text(column);
  endLine();
}

CsvFile& CsvFile::text(const std::string& text) {
  separate();
  buffer_ += text;
  return *this;
}

CsvFile& CsvFile::quoted(const std::string& text) {
  separate();
  buffer_ += '"';
  for (const char c : text) {
    if (c == '"') buffer_ += '"';
    buffer_ += c;
  }
  buffer_ += '"';
  return *this;
}

CsvFile& CsvFile::number(double value, int digits) {
  separate();
  if (std::isfinite(value)) append(value, false, digits);
  return *this;
}

CsvFile& CsvFile::integer(long long value) {
  separate();
  buffer_ += std::to_string(value);
  return *this;
}

CsvFile& CsvFile::fixed(double value, int decimals) {
  separate();
  if (std::isfinite(value)) append(value, true, decimals);
  return *this;
}

void CsvFile::endLine() {
  buffer_ += '\n';
  row_started_ = false;
  if (buffer_.size() >= kFlushSize) flush();
}

void CsvFile::close() {
  flush();
  closeChecked(file_, path_);
}

void CsvFile::append(double value, bool fixed, int precision) {
  char digits[400];  // a fixed-point number as large as 1e308 with its decimals
  const auto result = std::to_chars(digits, digits + sizeof(digits), value,
                                    fixed ? std::chars_format::fixed : std::chars_format::general, precision);
  buffer_.append(digits, result.ptr);
}

void CsvFile::flush() {
  file_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
  buffer_.clear();
}

}  // namespace die_cushion_ident
