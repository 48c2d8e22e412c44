#pragma once
// The two text helpers every CSV reader of outside files uses (bench-rig logs, wheel-scene
// sequences, scripted encoder profiles, recorded drives, truth tables): trimming a cell and
// splitting a line. The readers keep their own rules for headers, comments and columns. No
// quoting: none of these files quotes a cell.
#include <string>
#include <string_view>
#include <vector>

namespace regolith {

/// `s` without leading and trailing blanks (space, tab, CR, LF).
inline std::string trim_blanks(std::string_view s) {
  constexpr std::string_view kBlanks = " \t\r\n";
  const auto b = s.find_first_not_of(kBlanks);
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(kBlanks);
  return std::string(s.substr(b, e - b + 1));
}

/// The comma-separated cells of one line, each trimmed: n commas give n + 1 cells ("a,b," has an
/// empty third cell), an empty line none.
inline std::vector<std::string> split_csv_line(std::string_view line) {
  std::vector<std::string> cells;
  if (line.empty()) return cells;
  for (std::size_t at = 0;;) {
    const std::size_t comma = line.find(',', at);
    const std::size_t end = comma == std::string_view::npos ? line.size() : comma;
    cells.push_back(trim_blanks(line.substr(at, end - at)));
    if (end == line.size()) break;
    at = end + 1;
  }
  return cells;
}

}  // namespace regolith
