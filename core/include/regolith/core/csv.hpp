#pragma once
// CSV files from outside (bench-rig logs, wheel-scene sequences, scripted encoder profiles,
// recorded drives, truth tables, the maps `regolith map` writes):
// - trim_blanks / split_csv_line, the two text helpers every reader uses;
// - CsvTable, a whole table whose header line names its columns, for the readers that look cells
//   up by column name (a recorded drive's frames.csv, the scored map's and truth's tables). Its
//   errors name the file, the line and the column.
// Readers with a fixed header or comment lines (bench logs, sequences) keep their own rules. No
// quoting: none of these files quotes a cell.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <initializer_list>
#include <string>
#include <string_view>
#include <vector>

#include "regolith/core/error.hpp"
#include "regolith/core/text_file.hpp"

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

/// A CSV table: the first non-blank line is the header naming the columns, every later non-blank
/// line a row (blank lines and a CR before the line end are ignored). Cells are looked up by
/// column name; a row shorter than the header reads its missing cells as empty. Every error is an
/// InputError naming the file and, for a cell, its line and column: "frames.csv:3: t_s: not a
/// number ('abc')".
class CsvTable {
 public:
  /// Largest file read() accepts (a drive's odometry table is ~100 bytes per frame).
  static constexpr std::uintmax_t kMaxBytes = 256u << 20;

  /// Reads the file `path` (read_text_file: a device, FIFO or oversized file is refused) and
  /// checks that the header has every column in `required`.
  static CsvTable read(const std::string& path, std::initializer_list<std::string_view> required = {}) {
    return parse(read_text_file(path, "CSV table", kMaxBytes), path, required);
  }

  /// The same from text; `name` is what errors call it.
  static CsvTable parse(std::string_view text, std::string name,
                        std::initializer_list<std::string_view> required = {}) {
    CsvTable t;
    t.name_ = std::move(name);
    int line_no = 0;
    for (std::size_t at = 0; at < text.size();) {
      const std::size_t end = std::min(text.find('\n', at), text.size());
      ++line_no;
      const std::string_view line = text.substr(at, end - at);
      at = end + 1;
      if (trim_blanks(line).empty()) continue;
      if (t.header_line_ == 0) {
        t.header_ = split_csv_line(line);
        t.header_line_ = line_no;
        continue;
      }
      t.rows_.push_back({line_no, split_csv_line(line)});
    }
    if (t.header_line_ == 0) throw InputError(t.name_ + ": empty (no header line)");
    for (std::string_view c : required)
      if (t.column(c) < 0)
        throw InputError(t.name_ + ":" + std::to_string(t.header_line_) + ": no column '" + std::string(c) +
                         "' in the header");
    return t;
  }

  const std::string& name() const { return name_; }
  const std::vector<std::string>& header() const { return header_; }
  /// Number of rows (the header not counted).
  std::size_t size() const { return rows_.size(); }
  /// The file's line number (1-based) of row `row`.
  int line(std::size_t row) const { return rows_.at(row).line; }
  /// Index of column `col` in the header, -1 when it has none.
  int column(std::string_view col) const {
    for (std::size_t k = 0; k < header_.size(); ++k)
      if (header_[k] == col) return static_cast<int>(k);
    return -1;
  }

  /// Every row has at least the header's number of cells, else "NAME:LINE: N fields, expected M".
  void require_complete() const {
    for (const Row& r : rows_)
      if (r.cells.size() < header_.size())
        throw InputError(name_ + ":" + std::to_string(r.line) + ": " + std::to_string(r.cells.size()) +
                         " fields, expected " + std::to_string(header_.size()));
  }

  /// The cell's text ("" when the row is short or the header has no such column).
  const std::string& text(std::size_t row, std::string_view col) const {
    static const std::string kEmpty;
    const int c = column(col);
    const Row& r = rows_.at(row);
    return c >= 0 && static_cast<std::size_t>(c) < r.cells.size() ? r.cells[static_cast<std::size_t>(c)] : kEmpty;
  }

  /// The cell as a number ("nan" and "inf" included: callers that need a finite value check),
  /// else "NAME:LINE: COL: not a number ('TEXT')".
  double number(std::size_t row, std::string_view col) const {
    double v = 0;
    if (!to_number(text(row, col), v)) fail(row, col, "not a number ('" + text(row, col) + "')");
    return v;
  }

  /// The cell as a number, NaN when it is empty, missing or not a number.
  double number_or_nan(std::size_t row, std::string_view col) const {
    double v = 0;
    return to_number(text(row, col), v) ? v : std::nan("");
  }

  /// The cell as a whole number in [lo, hi], else "NAME:LINE: COL: must be a whole number in
  /// LO..HI (got 'TEXT')".
  std::int64_t whole(std::size_t row, std::string_view col, std::int64_t lo, std::int64_t hi) const {
    double v = 0;
    if (!to_number(text(row, col), v) || !(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) ||
        v != std::floor(v))
      fail(row, col,
           "must be a whole number in " + std::to_string(lo) + ".." + std::to_string(hi) + " (got '" + text(row, col) +
               "')");
    return static_cast<std::int64_t>(v);
  }

  /// Throws "NAME:LINE: COL: WHY" for a cell a caller finds wrong.
  [[noreturn]] void fail(std::size_t row, std::string_view col, const std::string& why) const {
    throw InputError(name_ + ":" + std::to_string(line(row)) + ": " + std::string(col) + ": " + why);
  }

 private:
  struct Row {
    int line;
    std::vector<std::string> cells;
  };
  static bool to_number(const std::string& s, double& v) {
    if (s.empty()) return false;
    char* end = nullptr;
    v = std::strtod(s.c_str(), &end);
    return end == s.c_str() + s.size();
  }
  std::string name_;
  std::vector<std::string> header_;
  int header_line_ = 0;
  std::vector<Row> rows_;
};

}  // namespace regolith
