// Params: typed access, ranges, defaults, unknown keys, resolved values.
#include <gtest/gtest.h>

#include "error_of.hpp"
#include "regolith/core/params.hpp"

using namespace regolith;

namespace {
std::string error_of(const std::function<void()>& f) {
  return regolith::testing::error_of<ConfigError>(f);
}
}  // namespace

TEST(Params, TypedValuesDefaultsAndResolvedTable) {
  auto p = Params::load_string("a: 3\nb: [1, 2.5]\nc: hello\nd: true\n", "t.yaml");
  EXPECT_EQ(p.get<int>("a", 0, {.min = 0, .max = 10}), 3);
  EXPECT_EQ(p.get<std::vector<double>>("b", {}), (std::vector<double>{1.0, 2.5}));
  EXPECT_EQ(p.get<std::string>("c", ""), "hello");
  EXPECT_TRUE(p.get<bool>("d", false));
  EXPECT_DOUBLE_EQ(p.get<double>("e", 4.5, {.unit = "m"}), 4.5);
  p.finish();
  ASSERT_EQ(p.sink()->size(), 5u);
  EXPECT_EQ(p.sink()->back().path, "e");
  EXPECT_EQ(p.sink()->back().unit, "m");
  EXPECT_TRUE(p.sink()->back().defaulted);
}

TEST(Params, Errors) {
  auto p = Params::load_string("a: 1.5\nb: -2\nn: .nan\nlist: [1, x]\nflag: yes\n", "t.yaml");
  EXPECT_EQ(error_of([&] { p.get<int>("a", 0); }), "t.yaml:1:4: a: expected an integer, got '1.5'");
  EXPECT_EQ(error_of([&] { p.get<int>("b", 0, {.min = 0}); }), "t.yaml:2:4: b: value must be >= 0 (got -2)");
  EXPECT_EQ(error_of([&] { p.get<double>("n", 0.0); }), "t.yaml:3:4: n: must be a number, got NaN");
  EXPECT_EQ(error_of([&] { p.get<std::vector<double>>("list", {}); }),
            "t.yaml:4:7: list: expected a list of numbers, got '[1, x]'");
  EXPECT_EQ(error_of([&] { p.get<bool>("flag", false); }), "t.yaml:5:7: flag: expected true or false, got 'yes'");
  EXPECT_EQ(error_of([&] { p.require<double>("missing"); }), "t.yaml:1:1: missing: required double is missing");
}

TEST(Params, NestedPathsAndUnknownKeys) {
  auto p = Params::load_string("outer:\n  inner:\n    speed: 2\n    sped: 3\n", "t.yaml");
  auto inner = p.child("outer").child("inner");
  EXPECT_EQ(inner.get<int>("speed", 0), 2);
  EXPECT_EQ(error_of([&] { inner.finish(); }), "t.yaml:4:5: outer.inner.sped: unknown key (did you mean 'speed'?)");
}

TEST(Params, DidYouMean) {
  EXPECT_EQ(did_you_mean("rate_group", {"rate_groups", "components"}), "rate_groups");
  EXPECT_EQ(did_you_mean("zzzzzz", {"rate_groups", "components"}), "");
}

TEST(Params, ParseIntegerTakesWholeNumbersOnly) {
  std::int64_t v = 0;
  EXPECT_TRUE(parse_integer("42", v));
  EXPECT_EQ(v, 42);
  EXPECT_TRUE(parse_integer("-7", v));
  EXPECT_EQ(v, -7);
  EXPECT_TRUE(parse_integer("0x1f", v));
  EXPECT_EQ(v, 31);
  EXPECT_TRUE(parse_integer("9223372036854775807", v));
  EXPECT_EQ(v, INT64_MAX);
  for (const char* bad : {"", "1.5", "12abc", " ", "0x", "true", "9223372036854775808"}) {
    v = 5;
    EXPECT_FALSE(parse_integer(bad, v)) << "'" << bad << "'";
  }
}

TEST(Params, FieldErrorIsRelocatedAtItsKey) {
  // An algorithm's validate() knows the field, not the file: Params::fail(FieldError) points at
  // the key it was read from, and keeps the dotted sub-field in the path.
  auto root = Params::load_string("sfs:\n  iterations: 0\n  hub_center_px: [1, 2]\n", "deploy.yaml");
  Params p = root.child("sfs");
  const FieldError e("SfsParams", "iterations", "must be in 1..100000");
  EXPECT_STREQ(e.what(), "SfsParams.iterations: must be in 1..100000");
  EXPECT_EQ(error_of([&] { p.fail(e); }), "deploy.yaml:2:15: sfs.iterations: must be in 1..100000");
  EXPECT_EQ(error_of([&] { p.fail(FieldError("WheelGeometry", "hub_center_px.x", "must be finite")); }),
            "deploy.yaml:3:18: sfs.hub_center_px.x: must be finite");
  // A field that is not a key here (computed, or defaulted) is reported at the mapping.
  EXPECT_EQ(error_of([&] { p.fail(FieldError("", "width/height", "must be in 1..16384 px")); }),
            "deploy.yaml:2:3: sfs.width/height: must be in 1..16384 px");
  // Still a std::invalid_argument for code that only knows the standard type.
  EXPECT_THROW(throw FieldError("", "x", "bad"), std::invalid_argument);
}
