#pragma once
// A fresh directory under the system temp dir for one test, removed with everything in it when
// the object goes out of scope (retried briefly while a child process lets go of it): tests leave
// nothing behind in /tmp. The one temp-dir helper of the test suite (header-only, on every test
// target's include path).
//
//   regolith::testing::TempDir tmp("mapping_bad");   // /tmp/regolith_mapping_bad_<pid>_<n>
//   write(tmp / "input.json"); run(tmp.path());
//
// `TempDir tmp("e2e", TempDir::kKeepOnFailure)` keeps the directory when the running test has
// failed (and says where on stderr), for end-to-end tests whose logs are worth reading.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <system_error>
#include <thread>

#include <unistd.h>

#include <gtest/gtest.h>

namespace regolith::testing {

class TempDir {
 public:
  enum Keep { kRemoveAlways, kKeepOnFailure };

  explicit TempDir(const std::string& name = "test", Keep keep = kRemoveAlways) : keep_(keep) {
    static std::atomic<int> counter{0};
    path_ = std::filesystem::temp_directory_path() /
            ("regolith_" + name + "_" + std::to_string(::getpid()) + "_" + std::to_string(counter++));
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    if (keep_ == kKeepOnFailure && ::testing::Test::HasFailure()) {
      std::cerr << "test failed: its files are kept in " << path_.string() << "\n";
      return;
    }
    // A child process (a browser, a node script) may still be writing for a moment: retry, then
    // say what was left rather than throw from a destructor.
    std::error_code ec;
    for (int attempt = 0; attempt < 5; ++attempt) {
      std::filesystem::remove_all(path_, ec);
      if (!ec) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    std::cerr << "note: scratch " << path_.string() << " not removed: " << ec.message() << "\n";
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return path_ / name; }
  std::string str() const { return path_.string(); }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  /// Writes `text` into `name` (parent directories made).
  void write(const std::string& name, const std::string& text) const {
    std::filesystem::create_directories((path_ / name).parent_path());
    std::ofstream(path_ / name) << text;
  }

 private:
  std::filesystem::path path_;
  Keep keep_;
};

/// The whole file, bytes as they are ("" when it cannot be read: a child that wrote nothing).
inline std::string read_file(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

}  // namespace regolith::testing
