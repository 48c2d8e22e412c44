// core/json_file.hpp: the one reader of JSON descriptions (recorded drives, track scenes, truth).
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "regolith/core/json_file.hpp"
#include "temp_dir.hpp"

namespace {

using regolith::InputError;

std::string error_of(const auto& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no error)";
}

const nlohmann::json kDoc = nlohmann::json::parse(R"({"camera": {"fx": 300.5, "width": 640, "half": 320.5,
  "huge": 1e300, "name": "x"}, "flat": 3, "list": [1]})");

TEST(JsonFile, ReadsNumbersAtDottedPaths) {
  EXPECT_DOUBLE_EQ(regolith::json_number(kDoc, "in.json", "camera.fx"), 300.5);
  EXPECT_DOUBLE_EQ(regolith::json_number(kDoc, "in.json", "flat"), 3.0);
  EXPECT_FALSE(regolith::json_optional_number(kDoc, "in.json", "camera.roll_deg").has_value());
  EXPECT_FALSE(regolith::json_optional_number(kDoc, "in.json", "sun.azimuth_deg").has_value());
  EXPECT_EQ(regolith::json_pixels(kDoc, "in.json", "camera.width"), 640);
}

TEST(JsonFile, ErrorsNameTheFileAndTheField) {
  EXPECT_EQ(error_of([] { regolith::json_number(kDoc, "in.json", "sun.azimuth_deg"); }),
            "in.json: sun.azimuth_deg: missing");
  EXPECT_EQ(error_of([] { regolith::json_number(kDoc, "in.json", "camera.name"); }),
            "in.json: camera.name: must be a number");
  EXPECT_EQ(error_of([] { regolith::json_number(kDoc, "in.json", "flat.x"); }),
            "in.json: flat: must be an object (holding flat.x)");
  EXPECT_EQ(error_of([] { regolith::json_number(kDoc, "in.json", "list.x"); }),
            "in.json: list: must be an object (holding list.x)");
  const nlohmann::json array = nlohmann::json::array();
  EXPECT_EQ(error_of([&] { regolith::json_number(array, "in.json", "camera.fx"); }),
            "in.json: the document: must be an object (holding camera.fx)");
  // Sizes: whole pixels within the cameras' bound, refused before any cast.
  for (const char* f : {"camera.half", "camera.huge", "camera.fx"})
    EXPECT_EQ(error_of([&] { regolith::json_pixels(kDoc, "in.json", f); }),
              std::string("in.json: ") + f + ": must be a whole number of pixels, 1..16384");
}

TEST(JsonFile, ReadsAFileAndNamesItWhenItIsNotJson) {
  const regolith::testing::TempDir tmp("json_file");  // removed whatever the outcome
  const std::filesystem::path& dir = tmp.path();
  const std::string good = (dir / "good.json").string(), bad = (dir / "bad.json").string();
  std::ofstream(good) << R"({"a": {"b": 2}})";
  std::ofstream(bad) << R"({"a": )";
  EXPECT_DOUBLE_EQ(regolith::json_number(regolith::read_json_file(good, "test file"), good, "a.b"), 2.0);
  EXPECT_EQ(error_of([&] { regolith::read_json_file(bad, "test file"); }).rfind(bad + ": not valid JSON: ", 0), 0u);
  EXPECT_EQ(error_of([&] {
              regolith::read_json_file((dir / "absent.json").string(), "test file");
            }).rfind((dir / "absent.json").string() + ": cannot open test file", 0),
            0u);
}

}  // namespace
