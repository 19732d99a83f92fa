// CsvFile, the tools' one CSV writer: what a reader of estimates.csv or trend.csv may rely on.
#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <sstream>
#include <string>

#include "output/csv_file.h"
#include "output/output_files.h"

namespace die_cushion_ident {
namespace {

std::string temporaryPath(const std::string& name) {
  return "/tmp/die_cushion_ident_test_csv_" + std::to_string(::getpid()) + "_" + name;
}

std::string contents(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(CsvFile, SeparatesTheFieldsOfARowAndStartsEachRowAfresh) {
  const std::string path = temporaryPath("rows.csv");
  CsvFile csv(path);
  csv.header({"t", "p"});
  csv.fixed(1.5, 6).number(2e5).endLine();
  csv.close();
  EXPECT_EQ(contents(path), "t,p\n1.500000,200000\n");
  std::remove(path.c_str());
}

TEST(CsvFile, WritesNumbersAsPrintfsGeneralFormatWithTheStatedDigits) {
  const std::string path = temporaryPath("digits.csv");
  CsvFile csv(path);
  csv.number(1.0 / 3.0).number(1.0 / 3.0, 6).number(1.234e-12, 3).number(1e21).number(-0.5).integer(-42);
  csv.endLine();
  csv.close();
  char expected[256];
  std::snprintf(expected, sizeof(expected), "%.10g,%.6g,%.3g,%.10g,%.10g,-42\n", 1.0 / 3.0, 1.0 / 3.0,
                1.234e-12, 1e21, -0.5);
  EXPECT_EQ(contents(path), expected);
  std::remove(path.c_str());
}

TEST(CsvFile, LeavesAFieldEmptyWhereANumberIsNotFinite) {
  const std::string path = temporaryPath("missing.csv");
  CsvFile csv(path);
  const double inf = std::numeric_limits<double>::infinity();
  csv.number(std::nan("")).number(inf).fixed(-inf, 3).number(1.0).endLine();
  csv.close();
  EXPECT_EQ(contents(path), ",,,1\n");
  std::remove(path.c_str());
}

TEST(CsvFile, QuotesTextThatMayHoldCommasAndDoublesItsQuotes) {
  const std::string path = temporaryPath("quoted.csv");
  CsvFile csv(path);
  csv.quoted("/bags/a, b.bag").quoted("k*\"p\"").text("x").endLine();
  csv.close();
  EXPECT_EQ(contents(path), "\"/bags/a, b.bag\",\"k*\"\"p\"\"\",x\n");
  std::remove(path.c_str());
}

TEST(CsvFile, KeepsEveryRowOfAFileLargerThanItsBuffer) {
  const std::string path = temporaryPath("large.csv");
  CsvFile csv(path);
  const int rows = 50000;  // about 0.6 MB: several flushes of the 64 kB buffer
  for (int k = 0; k < rows; ++k) csv.integer(k).number(k * 0.001).endLine();
  csv.close();
  std::ifstream in(path);
  std::string line;
  int count = 0;
  while (std::getline(in, line)) {
    const auto comma = line.find(',');
    ASSERT_NE(comma, std::string::npos);
    ASSERT_EQ(std::stoi(line.substr(0, comma)), count);
    ++count;
  }
  EXPECT_EQ(count, rows);
  std::remove(path.c_str());
}

TEST(CsvFile, ThrowsAWriteErrorWhenTheFileCannotBeWritten) {
  CsvFile csv("/nonexistent_directory_of_die_cushion_ident/out.csv");
  csv.text("t").endLine();
  EXPECT_THROW(csv.close(), WriteError);
}

}  // namespace
}  // namespace die_cushion_ident
