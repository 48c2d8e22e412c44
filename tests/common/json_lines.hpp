#pragma once
// JSON lines as `regolith echo` prints them (one sample per line), for the end-to-end tests
// (header-only, on every test target's include path; the target links nlohmann_json).
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace regolith::testing {

/// Every non-empty line of `file` parsed as JSON (a line that is not JSON throws
/// nlohmann::json::parse_error: the printer is under test); none when the file is missing.
inline std::vector<nlohmann::json> read_json_lines(const std::filesystem::path& file) {
  std::vector<nlohmann::json> out;
  std::ifstream in(file);
  for (std::string line; std::getline(in, line);)
    if (!line.empty()) out.push_back(nlohmann::json::parse(line));
  return out;
}

/// header.stamp of a printed ROS 2 message, in ns.
inline std::int64_t header_stamp_ns(const nlohmann::json& m) {
  return m["header"]["stamp"]["sec"].get<std::int64_t>() * 1000000000LL +
         m["header"]["stamp"]["nanosec"].get<std::int64_t>();
}

}  // namespace regolith::testing
