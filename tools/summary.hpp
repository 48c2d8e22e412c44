#pragma once
#include <ostream>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::cli {

/// The live summary of `regolith run` (rate groups, cycle times, slips, devices, samples
/// published), produced off the real-time threads. Faults, recoveries and slips are logged as
/// events by the application (runtime/event_log.hpp), on the console and on /rosout.
class Summary {
 public:
  Summary(runtime::Application& app, bool redraw);
  void print(std::ostream& os, bool final = false);

 private:
  runtime::Application& app_;
  bool redraw_;
  int lines_printed_ = 0;
  TimeNs start_wall_;
  TimeNs start_clock_;
};

void print_resolved(std::ostream& os, const std::vector<ResolvedParam>& params);

}  // namespace regolith::cli
