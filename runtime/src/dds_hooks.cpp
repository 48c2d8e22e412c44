#include "regolith/runtime/dds_hooks.hpp"

namespace regolith::dds {
class Participant {};
}

namespace regolith::runtime {

void declare_dds_params(Params& dds) {
  dds.get<bool>("enabled", true, {.doc = "publish on DDS"});
  dds.get<int>("domain", 0, {.min = 0, .max = 232, .doc = "DDS domain id (ROS_DOMAIN_ID)"});
  dds.get<std::string>("namespace", "", {.doc = "topic namespace, e.g. rover1 -> rt/rover1/joint_states"});
}

std::shared_ptr<dds::Participant> make_participant(Params& dds) {
  declare_dds_params(dds);
  return nullptr;
}
void start_participant(dds::Participant&) {}
void stop_participant(dds::Participant&) {}

}  // namespace regolith::runtime

namespace regolith::runtime {
std::string dds_summary(dds::Participant&) { return {}; }
}  // namespace regolith::runtime
