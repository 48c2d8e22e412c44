// Accuracy evaluation over paired (truth, estimate) samples: thesis Table 4.1 analogue.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "regolith/sinkage/sinkage.hpp"

namespace regolith::sinkage {

EvalSummary evaluate(std::span<const EvalSample> samples) {
  EvalSummary s;
  s.frames = samples.size();
  double sum_abs = 0, sum_sq = 0, sum_truth = 0;
  for (const EvalSample& e : samples) {
    if (!std::isfinite(e.truth_mm)) continue;
    s.max_truth_mm = std::max(s.max_truth_mm, e.truth_mm);
    if (!e.valid || !std::isfinite(e.estimate_mm)) continue;
    ++s.valid;
    const double err = std::abs(e.estimate_mm - e.truth_mm);
    sum_abs += err;
    sum_sq += err * err;
    sum_truth += e.truth_mm;
    s.max_abs_error_mm = std::max(s.max_abs_error_mm, err);
  }
  if (s.valid == 0) return s;
  const auto n = static_cast<double>(s.valid);
  s.mean_abs_error_mm = sum_abs / n;
  s.rms_error_mm = std::sqrt(sum_sq / n);
  s.mean_truth_mm = sum_truth / n;
  if (s.mean_truth_mm > 0) s.mean_error_pct_of_mean_truth = 100.0 * s.mean_abs_error_mm / s.mean_truth_mm;
  if (s.max_truth_mm > 0) {
    s.mean_error_pct_of_max_truth = 100.0 * s.mean_abs_error_mm / s.max_truth_mm;
    s.max_error_pct_of_max_truth = 100.0 * s.max_abs_error_mm / s.max_truth_mm;
  }
  return s;
}

EvalSummary evaluate_sequence(SinkageEstimator& estimator, std::span<const SequenceItem> sequence,
                              std::vector<EvalSample>* samples_out) {
  std::vector<EvalSample> samples;
  samples.reserve(sequence.size());
  estimator.reset_filter();
  SinkageResult r;
  for (const SequenceItem& item : sequence) {
    estimator.process(item.bgr, item.encoder_angle_rad, r);
    samples.push_back({item.truth_mm, r.valid ? r.sinkage_mm : 0.0, r.valid});
  }
  const EvalSummary s = evaluate(samples);
  if (samples_out != nullptr) *samples_out = std::move(samples);
  return s;
}

std::string format_table(std::span<const ConditionSummary> rows) {
  std::ostringstream os;
  char line[256];
  std::snprintf(line, sizeof line, "%-10s %-14s %7s %6s %10s %10s %9s %9s %9s\n", "load", "illumination", "frames",
                "valid", "mean[mm]", "max[mm]", "mean[%GT]", "mean[%max]", "max[%max]");
  os << line;
  for (const ConditionSummary& r : rows) {
    const EvalSummary& s = r.summary;
    std::snprintf(line, sizeof line, "%-10s %-14s %7zu %6zu %10.2f %10.2f %9.1f %9.1f %9.1f\n", r.load.c_str(),
                  r.illumination.c_str(), s.frames, s.valid, s.mean_abs_error_mm, s.max_abs_error_mm,
                  s.mean_error_pct_of_mean_truth, s.mean_error_pct_of_max_truth, s.max_error_pct_of_max_truth);
    os << line;
  }
  return os.str();
}

}  // namespace regolith::sinkage
