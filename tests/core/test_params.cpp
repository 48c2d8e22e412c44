// Params: typed access, ranges, defaults, unknown keys, resolved values.
#include <gtest/gtest.h>

#include "regolith/core/params.hpp"

using namespace regolith;

namespace {
std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "<no error>";
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
