#pragma once
// The ROS 2 environment of a process: its domain and how far discovery reaches, read the way ROS 2
// reads it, and turned into the Cyclone DDS configuration rmw_cyclonedds gives the same variables,
// so that regolith and ROS 2 nodes started with the same environment find each other (and nothing
// else does).
//
//   ROS_DOMAIN_ID                  0..232 (unset or empty: 0)
//   ROS_AUTOMATIC_DISCOVERY_RANGE  SUBNET (default) | LOCALHOST | OFF | SYSTEM_DEFAULT (ROS 2 Iron+)
//   ROS_STATIC_PEERS               hosts to discover by unicast, separated by ';' (Iron+)
//   ROS_LOCALHOST_ONLY=1           Humble's spelling of LOCALHOST (used when the range is unset)
//
// A value ROS 2 would refuse is a ConfigError naming the variable (a typo must not silently put a
// rover on domain 0 beside another run).
#include <string>
#include <vector>

namespace regolith::dds {

enum class DiscoveryRange {
  kSubnet,         ///< multicast on the network (DDS's own default), plus the static peers
  kLocalhost,      ///< this machine only: no multicast, localhost as a unicast peer (+ the static peers)
  kOff,            ///< no discovery beyond this process: no multicast, no peers, a private domain tag
  kSystemDefault,  ///< the DDS configuration as it is (CYCLONEDDS_URI); static peers ignored
};

struct DiscoveryOptions {
  DiscoveryRange range = DiscoveryRange::kSubnet;
  std::vector<std::string> static_peers;  ///< host names or addresses
  bool operator==(const DiscoveryOptions&) const = default;
};

/// ROS_DOMAIN_ID: 0 when unset or empty; ConfigError naming it when it is not an integer in 0..232.
int domain_id_from_environment();
/// ROS_AUTOMATIC_DISCOVERY_RANGE, ROS_STATIC_PEERS and ROS_LOCALHOST_ONLY; ConfigError naming the
/// variable for a value ROS 2 does not know.
DiscoveryOptions discovery_from_environment();
/// "SUBNET", "LOCALHOST", "OFF", "SYSTEM_DEFAULT".
const char* to_string(DiscoveryRange r);

/// The Cyclone DDS configuration fragment (XML, to be followed by CYCLONEDDS_URI's own) that gives
/// `o`, as rmw_cyclonedds builds it: LOCALHOST = multicast off, localhost and the static peers as
/// unicast peers, participant indices on (so peers on one host find each other's ports); OFF =
/// multicast off and a domain tag private to `pid`; SUBNET with static peers = those peers added.
/// Empty (nothing to add) for SUBNET without peers and for SYSTEM_DEFAULT.
std::string discovery_config(const DiscoveryOptions& o, long pid);

}  // namespace regolith::dds
