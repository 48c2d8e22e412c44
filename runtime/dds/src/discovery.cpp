#include "regolith/dds/discovery.hpp"

#include <cctype>
#include <cstdlib>

#include "regolith/core/error.hpp"

namespace regolith::dds {
namespace {

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v != nullptr ? std::string(v) : std::string();
}

std::string trimmed(const std::string& s) {
  std::size_t b = 0, e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

// An address or host name as it may stand in an XML attribute: no quotes, angle brackets or
// ampersands (anything else is Cyclone's to resolve, and its error names the peer).
bool plausible_peer(const std::string& p) {
  if (p.empty() || p.size() > 255) return false;
  for (char c : p)
    if (c == '"' || c == '<' || c == '>' || c == '&' || c == '\'' || std::isspace(static_cast<unsigned char>(c)))
      return false;
  return true;
}

}  // namespace

int domain_id_from_environment() {
  const std::string v = trimmed(env("ROS_DOMAIN_ID"));
  if (v.empty()) return 0;
  char* end = nullptr;
  const long id = std::strtol(v.c_str(), &end, 10);
  if (*end != '\0' || v.size() > 3 || id < 0 || id > 232)
    throw ConfigError("ROS_DOMAIN_ID='" + v + "': must be an integer in 0..232 (the ROS 2 domain id)");
  return static_cast<int>(id);
}

const char* to_string(DiscoveryRange r) {
  switch (r) {
    case DiscoveryRange::kSubnet: return "SUBNET";
    case DiscoveryRange::kLocalhost: return "LOCALHOST";
    case DiscoveryRange::kOff: return "OFF";
    case DiscoveryRange::kSystemDefault: return "SYSTEM_DEFAULT";
  }
  return "?";
}

DiscoveryOptions discovery_from_environment() {
  DiscoveryOptions o;
  const std::string range = trimmed(env("ROS_AUTOMATIC_DISCOVERY_RANGE"));
  const std::string localhost_only = trimmed(env("ROS_LOCALHOST_ONLY"));
  if (!localhost_only.empty() && localhost_only != "0" && localhost_only != "1")
    throw ConfigError("ROS_LOCALHOST_ONLY='" + localhost_only + "': must be 0 or 1");
  if (range.empty()) {
    o.range = localhost_only == "1" ? DiscoveryRange::kLocalhost : DiscoveryRange::kSubnet;
  } else if (range == "SUBNET") {
    o.range = DiscoveryRange::kSubnet;
  } else if (range == "LOCALHOST") {
    o.range = DiscoveryRange::kLocalhost;
  } else if (range == "OFF") {
    o.range = DiscoveryRange::kOff;
  } else if (range == "SYSTEM_DEFAULT") {
    o.range = DiscoveryRange::kSystemDefault;
  } else {
    throw ConfigError("ROS_AUTOMATIC_DISCOVERY_RANGE='" + range +
                      "': must be SUBNET, LOCALHOST, OFF or SYSTEM_DEFAULT");
  }
  const std::string peers = env("ROS_STATIC_PEERS");
  std::size_t start = 0;
  while (start <= peers.size()) {
    const std::size_t end = std::min(peers.find(';', start), peers.size());
    const std::string p = trimmed(peers.substr(start, end - start));
    if (!p.empty()) {
      if (!plausible_peer(p))
        throw ConfigError("ROS_STATIC_PEERS: '" + p + "' is not a host name or address (peers are separated by ';')");
      o.static_peers.push_back(p);
    }
    start = end + 1;
  }
  return o;
}

std::string discovery_config(const DiscoveryOptions& o, long pid) {
  const bool localhost_peer = o.range == DiscoveryRange::kLocalhost;
  const bool no_multicast = o.range == DiscoveryRange::kLocalhost || o.range == DiscoveryRange::kOff;
  const bool peers =
      (o.range == DiscoveryRange::kSubnet || o.range == DiscoveryRange::kLocalhost) && !o.static_peers.empty();
  if (!localhost_peer && !no_multicast && !peers) return {};
  std::string x = "<CycloneDDS><Domain>";
  if (no_multicast) x += "<General><AllowMulticast>false</AllowMulticast></General>";
  x += "<Discovery>";
  if (o.range == DiscoveryRange::kOff) {
    // Nobody else carries this tag: the participant discovers no one and no one discovers it.
    x += "<ParticipantIndex>none</ParticipantIndex><Tag>ros_discovery_off_" + std::to_string(pid) + "</Tag>";
  } else {
    // Unicast discovery needs each participant on a host at a known port: indices 0..32.
    x += "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>32</MaxAutoParticipantIndex>";
    if (localhost_peer || peers) {
      x += "<Peers>";
      if (localhost_peer) x += "<Peer address=\"localhost\"/>";
      if (peers)
        for (const auto& p : o.static_peers) x += "<Peer address=\"" + p + "\"/>";
      x += "</Peers>";
    }
  }
  x += "</Discovery></Domain></CycloneDDS>";
  return x;
}

}  // namespace regolith::dds
