// The CSV helpers shared by the readers of bench logs, wheel-scene sequences, scripted encoder
// profiles, recorded drives and scored maps (regolith/core/csv.hpp).
#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "error_of.hpp"
#include "regolith/core/csv.hpp"
#include "regolith/core/error.hpp"
#include "temp_dir.hpp"

using regolith::CsvTable;
using regolith::InputError;
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

namespace {
std::string error_of(const auto& f) {
  return regolith::testing::error_of<InputError>(f);
}
}  // namespace

TEST(CsvTable, LooksCellsUpByColumnAndKnowsTheirLines) {
  const CsvTable t = CsvTable::parse("\n frame , x_m,name\r\n0,1.5,a\n\n1,-2e-3\n", "t.csv", {"frame", "x_m"});
  EXPECT_EQ(t.header(), (Cells{"frame", "x_m", "name"}));
  ASSERT_EQ(t.size(), 2u);
  EXPECT_EQ(t.line(0), 3);
  EXPECT_EQ(t.line(1), 5);  // blank lines are skipped but counted
  EXPECT_EQ(t.column("name"), 2);
  EXPECT_EQ(t.column("y_m"), -1);
  EXPECT_EQ(t.whole(1, "frame", 0, 10), 1);
  EXPECT_DOUBLE_EQ(t.number(0, "x_m"), 1.5);
  EXPECT_DOUBLE_EQ(t.number(1, "x_m"), -2e-3);
  EXPECT_EQ(t.text(0, "name"), "a");
  EXPECT_EQ(t.text(1, "name"), "");  // a short row reads its missing cells as empty
  EXPECT_EQ(t.text(0, "absent"), "");
  EXPECT_TRUE(std::isnan(t.number_or_nan(1, "name")));
  EXPECT_TRUE(std::isnan(t.number_or_nan(0, "name")));  // "a"
  EXPECT_EQ(error_of([&] { t.require_complete(); }), "t.csv:5: 2 fields, expected 3");
}

TEST(CsvTable, ErrorsNameTheFileTheLineAndTheColumn) {
  const auto without_c = [] { CsvTable::parse("a,b\n1,2\n", "t.csv", {"a", "c"}); };
  EXPECT_EQ(error_of(without_c), "t.csv:1: no column 'c' in the header");
  EXPECT_EQ(error_of([] { CsvTable::parse(" \n\r\n", "t.csv"); }), "t.csv: empty (no header line)");
  const CsvTable t = CsvTable::parse("frame,v\n2.5,1x\n-1,nan\n1e308,inf\n", "t.csv");
  EXPECT_EQ(error_of([&] { t.number(0, "v"); }), "t.csv:2: v: not a number ('1x')");
  EXPECT_TRUE(std::isnan(t.number(1, "v")));  // "nan" is a number: callers that need a finite one say so
  EXPECT_TRUE(std::isinf(t.number(2, "v")));
  EXPECT_EQ(error_of([&] { t.whole(0, "frame", 0, 9); }), "t.csv:2: frame: must be a whole number in 0..9 (got '2.5')");
  EXPECT_EQ(error_of([&] { t.whole(1, "frame", 0, 9); }), "t.csv:3: frame: must be a whole number in 0..9 (got '-1')");
  EXPECT_EQ(error_of([&] { t.whole(2, "frame", 0, 9); }),
            "t.csv:4: frame: must be a whole number in 0..9 (got '1e308')");
  EXPECT_EQ(error_of([&] { t.fail(2, "v", "must be finite"); }), "t.csv:4: v: must be finite");
}

TEST(CsvTable, ReadRefusesWhatIsNotAFileOfTableSize) {
  const regolith::testing::TempDir tmp("csv_table");
  const std::string path = (tmp.path() / "t.csv").string();
  EXPECT_NE(error_of([&] { CsvTable::read(path); }).find(path + ": cannot open"), std::string::npos);
  std::ofstream(path) << "a,b\n1,2\n";
  EXPECT_EQ(CsvTable::read(path, {"b"}).number(0, "b"), 2.0);
  EXPECT_NE(error_of([] { CsvTable::read("/dev/zero"); }).find("/dev/zero: not a regular file"), std::string::npos);
  EXPECT_NE(error_of([&] { CsvTable::read(tmp.path().string()); }).find("not a regular file"), std::string::npos);
}
