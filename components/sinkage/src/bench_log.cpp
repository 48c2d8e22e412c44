// Bench-rig log CSV (vision vs linear transducer), see bench_log.hpp.
#include "regolith/sinkage/bench_log.hpp"

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

#include "regolith/core/csv.hpp"

namespace regolith::sinkage {
namespace {

constexpr const char* kHeader =
    "time_s,sequence,encoder_angle_rad,vision_mm,valid,confidence,reason,transducer_mm,load,illumination";
constexpr int kColumns = 10;
constexpr const char* kNames[kColumns] = {"time_s",     "sequence", "encoder_angle_rad", "vision_mm", "valid",
                                          "confidence", "reason",   "transducer_mm",     "load",      "illumination"};

[[noreturn]] void bad(const std::filesystem::path& f, int line, const std::string& what) {
  throw std::runtime_error(f.string() + ":" + std::to_string(line) + ": " + what);
}

/// A number; "nan" allowed when `nan_ok`.
double number(const std::string& t, const std::filesystem::path& f, int line, int col, bool nan_ok) {
  if (nan_ok && (t == "nan" || t == "NaN" || t == "")) return std::nan("");
  char* end = nullptr;
  const double v = std::strtod(t.c_str(), &end);
  if (t.empty() || end != t.c_str() + t.size() || !std::isfinite(v)) {
    bad(f, line,
        std::string("column ") + kNames[col] + ": expected a " + (nan_ok ? "number or nan" : "finite number") +
            " (got '" + t + "')");
  }
  return v;
}

void put_double(char* buf, std::size_t size, std::size_t& n, double v, int decimals) {
  if (n >= size) return;
  const int w = std::isfinite(v) ? std::snprintf(buf + n, size - n, "%.*f", decimals, v)
                                 : std::snprintf(buf + n, size - n, "nan");
  if (w > 0) n += static_cast<std::size_t>(w);
}

}  // namespace

const char* bench_log_header() {
  return kHeader;
}

std::size_t format_bench_log_row(char* buf, std::size_t size, double time_s, std::uint64_t sequence,
                                 double encoder_angle_rad, double vision_mm, bool valid, double confidence,
                                 const char* reason, double transducer_mm, const char* load, const char* illumination) {
  if (size == 0) return 0;
  std::size_t n = 0;
  const int w = std::snprintf(buf, size, "%.6f,%llu,", time_s, static_cast<unsigned long long>(sequence));
  if (w > 0) n = static_cast<std::size_t>(w);
  put_double(buf, size, n, encoder_angle_rad, 6);
  if (n + 1 < size) buf[n++] = ',';
  put_double(buf, size, n, vision_mm, 3);
  if (n < size) {
    const int w2 = std::snprintf(buf + n, size - n, ",%d,%.3f,%s,", valid ? 1 : 0, confidence, reason);
    if (w2 > 0) n += static_cast<std::size_t>(w2);
  }
  put_double(buf, size, n, transducer_mm, 3);
  if (n < size) {
    const int w3 = std::snprintf(buf + n, size - n, ",%s,%s", load, illumination);
    if (w3 > 0) n += static_cast<std::size_t>(w3);
  }
  return n < size ? n : size - 1;
}

std::vector<BenchLogRow> read_bench_log(const std::filesystem::path& csv) {
  std::ifstream is(csv);
  if (!is) throw std::runtime_error(csv.string() + ": cannot open");
  std::vector<BenchLogRow> rows;
  std::string line;
  int n = 0;
  bool header = false;
  while (std::getline(is, line)) {
    ++n;
    const std::string t = trim_blanks(line);
    if (t.empty() || t[0] == '#') continue;
    const std::vector<std::string> cols = split_csv_line(t);
    if (!header) {
      if (t != kHeader) bad(csv, n, std::string("expected header '") + kHeader + "' (got '" + t + "')");
      header = true;
      continue;
    }
    if (static_cast<int>(cols.size()) != kColumns) {
      bad(csv, n, "expected " + std::to_string(kColumns) + " columns (got " + std::to_string(cols.size()) + ")");
    }
    BenchLogRow r;
    r.line = n;
    r.time_s = number(cols[0], csv, n, 0, false);
    const double seq = number(cols[1], csv, n, 1, false);
    if (seq < 0 || seq != std::floor(seq))
      bad(csv, n, "column sequence: expected a non-negative integer (got '" + cols[1] + "')");
    r.sequence = static_cast<std::uint64_t>(seq);
    r.encoder_angle_rad = number(cols[2], csv, n, 2, true);
    r.vision_mm = number(cols[3], csv, n, 3, true);
    if (cols[4] != "0" && cols[4] != "1") bad(csv, n, "column valid: expected 0 or 1 (got '" + cols[4] + "')");
    r.valid = cols[4] == "1";
    r.confidence = number(cols[5], csv, n, 5, false);
    r.reason = cols[6];
    r.transducer_mm = number(cols[7], csv, n, 7, true);
    r.load = cols[8];
    r.illumination = cols[9];
    if (r.valid && !std::isfinite(r.vision_mm)) bad(csv, n, "column vision_mm: nan in a valid row");
    rows.push_back(std::move(r));
  }
  if (!header) throw std::runtime_error(csv.string() + ": empty file (no header)");
  return rows;
}

}  // namespace regolith::sinkage
