// core/text_file.hpp: bounded reading of outside text files, and writing a whole output file with
// every failure (also one at the close) an error naming the file.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>

#include "error_of.hpp"
#include "regolith/core/text_file.hpp"
#include "temp_dir.hpp"

namespace {

using regolith::testing::error_of;

TEST(TextFile, WritesAndReadsBackAWholeFile) {
  regolith::testing::TempDir dir("text_file");
  const std::string path = (dir.path() / "out.csv").string();
  regolith::write_file(path, "a,b\n1,2\n", "the table");
  EXPECT_EQ(regolith::read_text_file(path, "table"), "a,b\n1,2\n");
  regolith::write_file(path, "x\n");  // truncated, not appended
  EXPECT_EQ(regolith::read_text_file(path), "x\n");
}

TEST(TextFile, AWriteThatFailsOnlyAtTheCloseIsAnErrorNamingTheFile) {
  // /dev/full accepts the open and the buffered write; the data reach it at the close: ENOSPC.
  if (!std::filesystem::exists("/dev/full")) GTEST_SKIP() << "no /dev/full on this system";
  EXPECT_EQ(error_of<regolith::InputError>([] { regolith::write_file("/dev/full", "x_m,y_m\n", "rocks.csv"); }),
            "/dev/full: cannot write rocks.csv (No space left on device)");
}

TEST(TextFile, AFileThatCannotBeOpenedIsAnErrorNamingIt) {
  regolith::testing::TempDir dir("text_file");
  const std::string path = (dir.path() / "no_such_dir" / "map.json").string();
  EXPECT_EQ(error_of<regolith::InputError>([&] { regolith::write_file(path, "{}", "map.json"); }),
            path + ": cannot write map.json (No such file or directory)");
}

TEST(TextFile, AnOutputDirectoryIsMadeWithItsParentsOrRefusedWithItsName) {
  regolith::testing::TempDir dir("text_file");
  const std::string nested = (dir.path() / "a" / "b").string();
  regolith::make_output_dir(nested);
  regolith::make_output_dir(nested);  // already there: fine
  EXPECT_TRUE(std::filesystem::is_directory(nested));
  regolith::write_file((dir.path() / "file").string(), "x");
  const std::string under_file = (dir.path() / "file" / "out").string();
  EXPECT_EQ(
      error_of<regolith::InputError>([&] { regolith::make_output_dir(under_file, "the map's output directory"); }),
      under_file + ": cannot create the map's output directory (Not a directory)");
  const std::string is_file = (dir.path() / "file").string();
  EXPECT_EQ(error_of<regolith::InputError>([&] { regolith::make_output_dir(is_file); }),
            is_file + ": cannot create the output directory (Not a directory)");
}

TEST(TextFile, ReadingRefusesADeviceWithItsName) {
  EXPECT_EQ(error_of<regolith::InputError>([] { regolith::read_text_file("/dev/zero", "deployment"); }),
            "/dev/zero: not a regular file (a device, FIFO or directory), not a deployment");
}

}  // namespace
