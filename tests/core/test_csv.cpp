// The CSV cell helpers shared by the readers of bench logs, wheel-scene sequences, scripted encoder
// profiles and recorded drives (regolith/core/csv.hpp).
#include "regolith/core/csv.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

using regolith::split_csv_line;
using regolith::trim_blanks;
using Cells = std::vector<std::string>;

TEST(Csv, TrimRemovesBlanksAtBothEndsOnly) {
  EXPECT_EQ(trim_blanks("  a b\t\r\n"), "a b");
  EXPECT_EQ(trim_blanks("x"), "x");
  EXPECT_EQ(trim_blanks(" \t\r\n"), "");
  EXPECT_EQ(trim_blanks(""), "");
}

TEST(Csv, SplitGivesOneCellMoreThanCommasEachTrimmed) {
  EXPECT_EQ(split_csv_line(""), Cells{});
  EXPECT_EQ(split_csv_line("a"), Cells{"a"});
  EXPECT_EQ(split_csv_line(" time_s , 1.5,x "), (Cells{"time_s", "1.5", "x"}));
  EXPECT_EQ(split_csv_line("a,,b"), (Cells{"a", "", "b"}));
  EXPECT_EQ(split_csv_line("a,b,"), (Cells{"a", "b", ""}));  // a trailing comma is an empty last cell
  EXPECT_EQ(split_csv_line(","), (Cells{"", ""}));
  EXPECT_EQ(split_csv_line("1,2\r"), (Cells{"1", "2"}));  // a CRLF file's line
}
