#pragma once
// The message of what a call throws, for the tests that check error messages (header-only, on
// every test target's include path, like temp_dir.hpp):
//
//   namespace rt = regolith::testing;
//   EXPECT_EQ(rt::error_of([] { parse("x"); }), "x: not a number");         // any std::exception
//   EXPECT_EQ(rt::error_of<ConfigError>([&] { load(p); }), "t.yaml:3:1: ..."); // only this type
//
// "<no exception>" when it throws nothing; an exception of another type than E reads
// "<other: what()>", so that a test expecting one error type fails on another with its message.
#include <exception>
#include <string>

namespace regolith::testing {

inline constexpr const char* kNoException = "<no exception>";

template <class E = std::exception, class F>
std::string error_of(F&& f) {
  try {
    try {
      f();
    } catch (const E& e) {
      return e.what();
    }
  } catch (const std::exception& e) {
    return std::string("<other: ") + e.what() + ">";
  }
  return kNoException;
}

}  // namespace regolith::testing
