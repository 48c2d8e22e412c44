#pragma once
// The runtime's seam to the DDS layer (runtime/dds): reading the `dds` section of a deployment and
// owning the participant's publisher thread.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/rover.hpp"
#include "regolith/core/time.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

/// Reads `dds: {enabled, domain, namespace}`; returns nullptr when disabled. `lossless` (simulated
/// time): stream writers keep all history so subscribers get every sample.
std::shared_ptr<dds::Participant> make_participant(Params& dds, bool lossless);
/// Declares the same parameters without creating anything (config check).
void declare_dds_params(Params& dds);
/// Starts the publisher thread. On a simulated `clock` every sample's DDS source timestamp is the
/// simulated ROS time of its cycle (to_ros_time(clock.now())), as its header stamp and /clock
/// are: recordings and subscribers then see the run on its own time line, not the wall clock's.
/// `clock` must outlive the participant's thread.
void start_participant(dds::Participant& p, const Clock& clock);
void stop_participant(dds::Participant& p);
/// Hand everything committed so far to DDS before simulated time moves on.
void sync_participant(dds::Participant& p);
/// The rover's fixed frames (static_transforms(rover)) on /tf_static: reliable, transient-local,
/// keep-last 1 (tf2's static broadcaster QoS), stamped `stamp` (process time). Returns the
/// writer, which must outlive the run (late subscribers get the transforms from it); nullptr
/// when the rover describes no frame.
std::shared_ptr<void> publish_static_transforms(dds::Participant& p, const RoverDescription& rover, TimeNs stamp);
/// Announces the process as one ROS 2 node named after the deployment on ros_discovery_info
/// (dds::Participant::announce_node) after every writer exists; logs the node's name.
void announce_node(dds::Participant& p, const std::string& deployment_name);
/// /clock (rosgraph_msgs/Clock) for simulated time: the returned function publishes the time it
/// is given (no allocation); call it after each simulated cycle.
std::function<void(TimeNs)> make_clock_publisher(dds::Participant& p);
/// Wait up to `timeout` for the writers of `topics` to have a matched reader; logs which have none.
void wait_for_readers(dds::Participant& p, const std::vector<std::string>& topics, TimeNs timeout);

}  // namespace regolith::runtime

namespace regolith::runtime {
/// One-line-per-topic summary of samples published / dropped (for the live summary).
std::string dds_summary(dds::Participant& p);
}  // namespace regolith::runtime
