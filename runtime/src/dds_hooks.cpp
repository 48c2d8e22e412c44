#include "regolith/runtime/dds_hooks.hpp"

#include <spdlog/spdlog.h>

#include "regolith/dds/participant.hpp"

namespace regolith::runtime {

namespace {
dds::ParticipantConfig read_config(Params& p, bool& enabled) {
  enabled = p.get<bool>("enabled", true, {.doc = "publish on DDS"});
  dds::ParticipantConfig c;
  c.domain_id = static_cast<std::uint32_t>(p.get<int>(
      "domain", dds::default_domain_id(),
      {.min = 0, .max = 232, .doc = "DDS domain id (default: the ROS_DOMAIN_ID environment variable, else 0)"}));
  c.ns = p.get<std::string>("namespace", "", {.doc = "topic namespace, e.g. rover1 -> rt/rover1/joint_states"});
  try {
    c.validate();
  } catch (const std::invalid_argument& e) {
    p.fail("namespace", e.what());
  }
  return c;
}
}  // namespace

void declare_dds_params(Params& p) {
  bool enabled = false;
  read_config(p, enabled);
}

std::shared_ptr<dds::Participant> make_participant(Params& p, bool lossless) {
  bool enabled = false;
  const dds::ParticipantConfig c = read_config(p, enabled);
  if (!enabled) return nullptr;
  try {
    auto participant = std::make_shared<dds::Participant>(c);
    participant->set_lossless(lossless);
    return participant;
  } catch (const std::exception& e) {
    p.fail({}, std::string("cannot create the DDS participant: ") + e.what());
  }
}

void start_participant(dds::Participant& p) { p.start(); }
void sync_participant(dds::Participant& p) { p.drain(10 * kNsPerSec); }
void wait_for_readers(dds::Participant& p, const std::vector<std::string>& topics, TimeNs timeout) {
  if (!p.wait_for_readers(topics, timeout)) {
    for (const auto& t : topics) {
      for (const auto& s : p.stats()) {
        if (s.topic == p.ros_name(t) && s.matched_readers == 0)
          spdlog::warn("no subscriber on {} after {:.0f} s; starting anyway", s.topic, to_seconds(timeout));
      }
    }
  }
}
void stop_participant(dds::Participant& p) {
  // Let matched readers acknowledge what was published before the writers go away.
  p.wait_for_acks(2 * kNsPerSec);
  p.stop();
}
std::string dds_summary(dds::Participant& p) { return p.summary(); }

}  // namespace regolith::runtime
