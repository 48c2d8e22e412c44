#include "regolith/dds/topics.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <ostream>
#include <sstream>
#include <stdexcept>

#include "regolith/core/json_text.hpp"
#include "regolith/dds/reader.hpp"

namespace regolith::dds {
namespace {

template <class Msg>
json render(const void* sample) {
  return to_json(*static_cast<const Msg*>(sample));
}

template <class Msg>
TopicInfo entry(std::string_view name, TopicClass cls) {
  return TopicInfo{name, MsgTraits<Msg>::ros_type, cls, MsgTraits<Msg>::descriptor(), &render<Msg>};
}

const std::array<TopicInfo, 17>& table() {
  static const std::array<TopicInfo, 17> t = {
      entry<msgs::sensor_msgs::JointState>("joint_states", TopicClass::kStream),
      entry<msgs::sensor_msgs::Imu>("imu", TopicClass::kStream),
      entry<msgs::diagnostic_msgs::DiagnosticArray>("/diagnostics", TopicClass::kDiagnostics),
      entry<msgs::grid_map_msgs::GridMap>("terrain/grid_map", TopicClass::kState),
      entry<msgs::regolith_msgs::RockArray>("terrain/rocks", TopicClass::kStream),
      entry<msgs::regolith_msgs::WheelSinkage>("terrain/wheel_sinkage", TopicClass::kStream),
      entry<msgs::regolith_msgs::SoilStiffness>("terrain/soil", TopicClass::kState),
      entry<msgs::nav_msgs::Odometry>("odom", TopicClass::kStream),
      entry<msgs::nav_msgs::Odometry>("odom/wheel", TopicClass::kStream),
      entry<msgs::grid_map_msgs::GridMap>("terrain/world_map", TopicClass::kState),
      entry<msgs::vision_msgs::Detection3DArray>("terrain/world_rocks", TopicClass::kState),
      entry<msgs::tf2_msgs::TFMessage>("/tf", TopicClass::kStream),
      entry<msgs::tf2_msgs::TFMessage>("/tf_static", TopicClass::kState),
      entry<msgs::rosgraph_msgs::Clock>("/clock", TopicClass::kStream),
      entry<msgs::rcl_interfaces::Log>("/rosout", TopicClass::kStream),
      entry<msgs::sensor_msgs::CompressedImage>("preview/rocks/compressed", TopicClass::kStream),
      entry<msgs::sensor_msgs::CompressedImage>("preview/sinkage/compressed", TopicClass::kStream),
  };
  return t;
}

std::string_view strip_slash(std::string_view s) {
  if (!s.empty() && s.front() == '/') s.remove_prefix(1);
  return s;
}

const char* class_name(TopicClass c) {
  switch (c) {
    case TopicClass::kState: return "state";
    case TopicClass::kStream: return "stream";
    case TopicClass::kDiagnostics: return "diagnostics";
  }
  return "?";
}

}  // namespace

QosProfile TopicInfo::writer_qos() const {
  switch (cls) {
    case TopicClass::kState: return QosProfile::state();
    case TopicClass::kStream: return QosProfile::stream(10);
    case TopicClass::kDiagnostics: return QosProfile::diagnostics();
  }
  return QosProfile::stream(10);
}

QosProfile TopicInfo::reader_qos() const {
  // Reliable readers lose nothing from our (reliable) writers; transient-local
  // only where the writers offer it (a transient-local reader does not match a
  // volatile writer).
  if (cls == TopicClass::kState) return QosProfile::reader(Reliability::kReliable, Durability::kTransientLocal, 1);
  return QosProfile::reader(Reliability::kReliable, Durability::kVolatile, 100);
}

std::span<const TopicInfo> known_topics() {
  return table();
}

const TopicInfo* find_topic(std::string_view name) {
  const std::string_view want = strip_slash(name);
  for (const auto& t : table())
    if (strip_slash(t.name) == want) return &t;
  return nullptr;
}

std::string list_topics(const Participant* p) {
  std::ostringstream os;
  for (const auto& t : table()) {
    const std::string shown = p != nullptr ? p->ros_name(t.name) : std::string(t.name);
    os << shown;
    for (std::size_t i = shown.size(); i < 28; ++i) os << ' ';
    os << ' ' << t.ros_type;
    for (std::size_t i = t.ros_type.size(); i < 36; ++i) os << ' ';
    os << ' ' << class_name(t.cls) << " (" << t.writer_qos().describe() << ")\n";
  }
  return os.str();
}

void add_receipt_time(json& sample, TimeNs received_ns) {
  sample["received"] = {{"sec", received_ns / kNsPerSec}, {"nanosec", received_ns % kNsPerSec}};
  const auto h = sample.find("header");
  if (h == sample.end() || !h->is_object()) return;
  const auto st = h->find("stamp");
  if (st == h->end() || !st->is_object() || !st->contains("sec") || !st->contains("nanosec")) return;
  const TimeNs stamp = (*st)["sec"].get<std::int64_t>() * kNsPerSec + (*st)["nanosec"].get<std::int64_t>();
  sample["delay_ms"] = static_cast<double>(received_ns - stamp) / 1e6;
}

std::size_t echo(Participant& p, std::string_view topic, const EchoOptions& opt, std::ostream& out) {
  const TopicInfo* t = find_topic(topic);
  if (t == nullptr) {
    std::string known;
    for (const auto& k : table()) known += (known.empty() ? "" : ", ") + std::string(strip_slash(k.name));
    throw std::invalid_argument("unknown topic '" + std::string(topic) + "' (known: " + known + ")");
  }
  QosProfile q = t->reader_qos();
  if (opt.best_effort) q.reliability = Reliability::kBestEffort;
  Subscription sub(p, t->name, t->descriptor, q);

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  std::size_t printed = 0;
  const auto done = [&] { return opt.count > 0 && printed >= opt.count; };
  while (!done()) {
    if (opt.keep_going && !opt.keep_going()) break;
    TimeNs slice = 100 * kNsPerMs;
    if (opt.timeout_ns > 0) {
      const TimeNs elapsed = std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start).count();
      if (elapsed >= opt.timeout_ns) break;
      slice = std::min(slice, opt.timeout_ns - elapsed);
    }
    if (!sub.wait(slice)) continue;
    const std::size_t max = opt.count > 0 ? opt.count - printed : 64;
    printed += sub.take(
        [&](const void* s, const dds_sample_info_t&) {
          json j = t->to_json(s);
          if (opt.receipt_time) add_receipt_time(j, realtime_now());
          out << regolith::json_text(j) << '\n';
        },
        max);
    out.flush();
  }
  return printed;
}

}  // namespace regolith::dds
