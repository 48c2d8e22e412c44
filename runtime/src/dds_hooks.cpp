#include "regolith/runtime/dds_hooks.hpp"

#include <algorithm>
#include <limits>

#include <spdlog/spdlog.h>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"

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

void start_participant(dds::Participant& p, const Clock& clock) {
  if (clock.simulated()) p.set_source_clock([&clock] { return to_ros_time(clock.now()); });
  p.start();
}

std::shared_ptr<void> publish_static_transforms(dds::Participant& p, const RoverDescription& rover, TimeNs stamp) {
  using Tf = msgs::tf2_msgs::TFMessage;
  const std::vector<FrameTransform> frames = static_transforms(rover);
  if (frames.empty()) return nullptr;
  std::size_t longest = 0;
  for (const auto& f : frames) longest = std::max({longest, f.parent.size(), f.child.size()});
  const auto n = static_cast<std::uint32_t>(frames.size());
  auto out = p.make_outbox<Tf>("/tf_static", dds::find_topic("/tf_static")->writer_qos(),
                               dds::OutboxOptions{dds::OutboxMode::kLatest, 2},
                               [n, longest](Tf& m) { dds::reserve(m, n, longest); });
  Tf* m = out->begin();
  if (m == nullptr) return out;
  dds::set_length(m->transforms, n);
  for (std::uint32_t i = 0; i < n; ++i) {
    const FrameTransform& f = frames[i];
    auto& t = m->transforms._buffer[i];
    dds::set_stamp(t.header.stamp, stamp);
    dds::copy_string(t.header.frame_id, longest, f.parent);
    dds::copy_string(t.child_frame_id, longest, f.child);
    t.transform.translation = {f.translation.x, f.translation.y, f.translation.z};
    t.transform.rotation = {f.rotation[0], f.rotation[1], f.rotation[2], f.rotation[3]};
  }
  out->commit();
  return out;
}

void announce_node(dds::Participant& p, const std::string& deployment_name) {
  try {
    const std::string node = p.announce_node(deployment_name);
    spdlog::info("ROS 2 graph: node {} ({} publishers) on ros_discovery_info", node, p.stats().size());
  } catch (const std::exception& e) {  // the graph entry is a convenience: never stop the rover for it
    spdlog::warn("cannot announce the ROS 2 node on ros_discovery_info: {}", e.what());
  }
}

std::function<void(TimeNs)> make_clock_publisher(dds::Participant& p) {
  using Clock = msgs::rosgraph_msgs::Clock;
  auto out = p.make_outbox<Clock>("/clock", dds::find_topic("/clock")->writer_qos(),
                                  dds::OutboxOptions{dds::OutboxMode::kLatest, 4}, [](Clock&) {});
  return [out, last = std::numeric_limits<TimeNs>::min()](TimeNs now) mutable {
    if (now <= last) return;  // several groups run at one simulated instant: one /clock sample
    last = now;
    if (Clock* c = out->begin()) {
      dds::set_stamp(c->clock, now);
      out->commit();
    }
  };
}
void sync_participant(dds::Participant& p) {
  p.drain(10 * kNsPerSec);
}
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
std::string dds_summary(dds::Participant& p) {
  return p.summary();
}

}  // namespace regolith::runtime
