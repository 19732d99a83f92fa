// The tools' shared command-line parser: the same errors in the same words for every tool.
#include <gtest/gtest.h>

#include "argument_parser.h"

namespace die_cushion_ident {
namespace {

struct Parsed {
  std::string out, bag;
  std::vector<std::string> customs;
  bool quiet = false;
  int jobs = 0;
  double hours = 0.0;
};

std::string parse(std::vector<const char*> argv, Parsed* p, ArgumentParser* parser = nullptr) {
  ArgumentParser local;
  ArgumentParser& arguments = parser ? *parser : local;
  arguments.option("--out", [p](const std::string& v) { p->out = v; })
      .option("--custom-effect", [p](const std::string& v) { p->customs.push_back(v); })
      .flag("--quiet", [p] { p->quiet = true; })
      .wholeNumber("--jobs", 1, 256, &p->jobs)
      .number("--hours", 0.0, 100.0, &p->hours)
      .positional("bag", 1, [p](const std::string& v) { p->bag = v; });
  argv.insert(argv.begin(), "tool");
  return arguments.parse(static_cast<int>(argv.size()), argv.data());
}

TEST(ArgumentParser, ReadsOptionsFlagsRepeatsAndThePositional) {
  Parsed p;
  EXPECT_EQ(parse({"a.bag", "--out", "dir", "--quiet", "--custom-effect", "x=p", "--custom-effect", "y=v",
                   "--jobs", "4", "--hours", "0.25"},
                  &p),
            "");
  EXPECT_EQ(p.bag, "a.bag");
  EXPECT_EQ(p.out, "dir");
  EXPECT_TRUE(p.quiet);
  EXPECT_EQ(p.customs, (std::vector<std::string>{"x=p", "y=v"}));
  EXPECT_EQ(p.jobs, 4);
  EXPECT_DOUBLE_EQ(p.hours, 0.25);
}

TEST(ArgumentParser, SaysWhatIsWrongInOneLine) {
  Parsed p;
  EXPECT_EQ(parse({"a.bag", "--out"}, &p), "--out needs a value");
  EXPECT_EQ(parse({"--bogus"}, &p), "unknown option --bogus");
  EXPECT_EQ(parse({"a.bag", "b.bag"}, &p), "unexpected argument 'b.bag' (only 1 bag expected)");
  EXPECT_EQ(parse({"--jobs", "2.5"}, &p), "--jobs needs a whole number in [1, 256], got '2.5'");
  EXPECT_EQ(parse({"--jobs", "0"}, &p), "--jobs needs a whole number in [1, 256], got '0'");
  EXPECT_EQ(parse({"--hours", "nan"}, &p), "--hours needs a number in [0, 100], got 'nan'");
  EXPECT_EQ(parse({"--hours", "1h"}, &p), "--hours needs a number in [0, 100], got '1h'");
  // A value that looks like an option is still the value (a negative number, a file named -x).
  EXPECT_EQ(parse({"--out", "-x"}, &p), "");
  EXPECT_EQ(p.out, "-x");
}

TEST(ArgumentParser, HandlersRefuseWithTheirOwnWordsAndHelpStopsParsing) {
  ArgumentParser arguments;
  arguments.option("--form", [](const std::string& v) {
    if (v != "integral") throw std::invalid_argument("--form must be integral, got '" + v + "'");
  });
  const char* bad[] = {"tool", "--form", "spline"};
  EXPECT_EQ(arguments.parse(3, bad), "--form must be integral, got 'spline'");
  ArgumentParser help;
  Parsed p;
  EXPECT_EQ(parse({"--help", "--bogus"}, &p, &help), "");
  EXPECT_TRUE(help.helpRequested());
}

}  // namespace
}  // namespace die_cushion_ident
