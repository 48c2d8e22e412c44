#pragma once
// Bench-rig log: one row per processed frame with the vision estimate next to the linear
// transducer's reading (ground truth), written by the `wheel_sinkage` component and read by
// `regolith eval sinkage --log FILE.csv`. Plain C++ (no runtime types).
//
// Format (CSV, '#' comment lines allowed anywhere):
//   time_s,sequence,encoder_angle_rad,vision_mm,valid,confidence,reason,transducer_mm,load,illumination
// time_s = frame capture time (s, process clock); encoder_angle_rad / transducer_mm may be "nan"
// (no angle at the capture time / no transducer sample); valid is 0/1; reason is the
// InvalidReason name ("none" when valid, "stale_encoder" / "no_encoder_angle" for encoder
// problems found by the component); load and illumination label the test condition.
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace regolith::sinkage {

struct BenchLogRow {
  double time_s = 0;
  std::uint64_t sequence = 0;
  double encoder_angle_rad = 0;  ///< NaN when not available
  double vision_mm = 0;
  bool valid = false;
  double confidence = 0;
  std::string reason;
  double transducer_mm = 0;  ///< NaN when not available
  std::string load;
  std::string illumination;
  int line = 0;  ///< line in the file (for messages)
};

/// The header line (without newline).
const char* bench_log_header();
/// One CSV line (without newline) into `buf` of `size` bytes, no allocation; returns the length
/// written (truncated to size - 1). Labels must not contain commas or newlines.
std::size_t format_bench_log_row(char* buf, std::size_t size, double time_s, std::uint64_t sequence,
                                 double encoder_angle_rad, double vision_mm, bool valid, double confidence,
                                 const char* reason, double transducer_mm, const char* load, const char* illumination);
/// Reads a log; throws std::runtime_error "FILE:LINE: ..." for a bad header or row.
std::vector<BenchLogRow> read_bench_log(const std::filesystem::path& csv);

}  // namespace regolith::sinkage
