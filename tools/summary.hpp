#pragma once
#include <ostream>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::cli {

/// The live summary of `regolith run` (rate groups, cycle times, slips, devices, samples
/// published) and the rate-limited warnings, both produced off the real-time threads.
class Summary {
 public:
  Summary(runtime::Application& app, bool redraw);
  void print(std::ostream& os, bool final = false);
  /// At most one warning per rate group / device per `interval`, with the count since the last.
  void warn_rate_limited(TimeNs interval = kNsPerSec);

 private:
  runtime::Application& app_;
  bool redraw_;
  int lines_printed_ = 0;
  TimeNs start_wall_;
  TimeNs start_clock_;
  std::vector<std::uint64_t> warned_slips_;
  std::vector<TimeNs> last_warn_;
  std::vector<std::uint64_t> warned_faults_;
};

void print_resolved(std::ostream& os, const std::vector<ResolvedParam>& params);

}  // namespace regolith::cli
