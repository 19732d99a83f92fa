// Counts in words: the thinned analysis says "every 32nd press cycle" (it said "32th" on an 8-hour
// recording, whose stride is 32).
#include <gtest/gtest.h>

#include "die_cushion_ident/core/util/formatted.h"

namespace die_cushion_ident {
namespace {

TEST(Formatted, OrdinalsReadAsEnglish) {
  EXPECT_EQ(ordinal(1), "1st");
  EXPECT_EQ(ordinal(2), "2nd");
  EXPECT_EQ(ordinal(3), "3rd");
  EXPECT_EQ(ordinal(4), "4th");
  EXPECT_EQ(ordinal(11), "11th");
  EXPECT_EQ(ordinal(12), "12th");
  EXPECT_EQ(ordinal(13), "13th");
  EXPECT_EQ(ordinal(32), "32nd");
  EXPECT_EQ(ordinal(112), "112th");
  EXPECT_EQ(ordinal(512), "512th");
  EXPECT_EQ(ordinal(1024), "1024th");
  EXPECT_EQ(ordinal(2048), "2048th");
}

TEST(Formatted, JoinedPutsTheSeparatorBetween) {
  EXPECT_EQ(joined({"a", "b", "c"}, ", "), "a, b, c");
  EXPECT_EQ(joined({}, ", "), "");
}

}  // namespace
}  // namespace die_cushion_ident
