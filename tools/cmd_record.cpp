// regolith record TOPIC... --out FILE.mcap: record regolith's DDS topics from a separate process
// into an MCAP file, like `ros2 bag record` (record/README.md). Samples are kept as the CDR bytes
// that were on the wire (dds_takecdr), one ros2msg Schema per ROS type (the .msg definitions of
// msgs/ros2, regolith::msgs::ros2msg_definition), one cdr Channel per topic (its ROS name, e.g.
// /rover1/joint_states); log_time = receive time, publish_time = the DDS source timestamp (both
// wall-clock ns since 1970). Stops on Ctrl-C / SIGTERM, --duration or --count and always closes
// the file (summary + footer).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdio>
#include <ctime>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/serialized.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/msgs/ros2msg.hpp"
#include "regolith/record/mcap_writer.hpp"

namespace regolith::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_stop_signal(int) {
  g_stop.store(true);
}

struct RecordArgs {
  std::vector<std::string> topics;
  std::string out;
  double duration_s = 0.0;
  std::size_t count = 0;
  int domain = dds::default_domain_id();
  std::string ns = "rover1";
  bool all = false;
  bool zstd = false;
  bool no_compression = false;
};

std::uint64_t realtime_ns() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<std::uint64_t>(ts.tv_sec) * 1'000'000'000ULL + static_cast<std::uint64_t>(ts.tv_nsec);
}

/// A QoS duration in rosbag2's YAML ({sec, nsec}); 0 = infinite, written as ROS 2 Humble writes
/// RMW_DURATION_INFINITE.
std::string yaml_duration(const char* key, TimeNs ns) {
  const long long sec = ns > 0 ? ns / kNsPerSec : 2147483647LL;
  const long long nsec = ns > 0 ? ns % kNsPerSec : 4294967295LL;
  return std::string("  ") + key + ":\n    sec: " + std::to_string(sec) + "\n    nsec: " + std::to_string(nsec) + "\n";
}

/// The channel metadata `offered_qos_profiles` rosbag2 (Humble) writes, so `ros2 bag play` offers
/// the same QoS (a latched map stays transient-local): the profile regolith's writers of the topic
/// use (TopicInfo::writer_qos()). Enum values of rmw: history 1 keep_last / 2 keep_all;
/// reliability 1 reliable / 2 best_effort; durability 1 transient_local / 2 volatile; liveliness 1
/// automatic.
std::string offered_qos_yaml(const dds::QosProfile& q) {
  std::string y = "- history: " + std::string(q.keep_all ? "2" : "1") + "\n";
  y += "  depth: " + std::to_string(q.keep_all ? 0 : q.depth) + "\n";
  y += "  reliability: " + std::string(q.reliability == dds::Reliability::kReliable ? "1" : "2") + "\n";
  y += "  durability: " + std::string(q.durability == dds::Durability::kTransientLocal ? "1" : "2") + "\n";
  y += yaml_duration("deadline", q.deadline_ns);
  y += yaml_duration("lifespan", 0);
  y += "  liveliness: 1\n";
  y += yaml_duration("liveliness_lease_duration", 0);
  y += "  avoid_ros_namespace_conventions: false";
  return y;
}

struct Recorded {
  const dds::TopicInfo* info = nullptr;
  std::string ros_name;
  std::unique_ptr<dds::Subscription> sub;
  std::uint16_t channel = 0;
  std::uint32_t sequence = 0;
  std::uint64_t count = 0;
};

void run_record(const RecordArgs& a) {
  std::vector<const dds::TopicInfo*> wanted;
  if (a.all) {
    for (const auto& t : dds::known_topics()) wanted.push_back(&t);
  }
  for (const auto& name : a.topics) {
    const dds::TopicInfo* t = dds::find_topic(name);
    if (t == nullptr) throw InputError("record: unknown topic '" + name + "'; known topics:\n" + dds::list_topics());
    if (std::find(wanted.begin(), wanted.end(), t) == wanted.end()) wanted.push_back(t);
  }
  if (wanted.empty())
    throw InputError("record: no topic given (name topics, e.g. joint_states /diagnostics, or --all)");

  // Before any reader exists: a publisher that sees our readers may signal us at once.
  std::signal(SIGINT, on_stop_signal);
  std::signal(SIGTERM, on_stop_signal);
  dds::Participant participant(dds::ParticipantConfig{static_cast<std::uint32_t>(a.domain), a.ns});
  record::McapWriterOptions wo;
  wo.compression = a.no_compression ? record::Compression::kNone : record::Compression::kZstd;
#ifdef REGOLITH_VERSION
  wo.library = std::string("regolith record ") + REGOLITH_VERSION;
#else
  wo.library = "regolith record";
#endif
  record::McapWriter writer(a.out, wo);          // throws when the file cannot be created
  std::map<std::string, std::uint16_t> schemas;  // ROS type -> schema id
  std::vector<Recorded> rec;
  dds::ReaderWaitSet waitset(participant.handle());
  for (const dds::TopicInfo* t : wanted) {
    const std::string type(t->ros_type);
    auto s = schemas.find(type);
    if (s == schemas.end()) {
      s = schemas.emplace(type, writer.add_schema(type, "ros2msg", msgs::ros2msg_definition(type))).first;
    }
    Recorded r;
    r.info = t;
    r.ros_name = participant.ros_name(t->name);
    r.channel =
        writer.add_channel(s->second, r.ros_name, "cdr", {{"offered_qos_profiles", offered_qos_yaml(t->writer_qos())}});
    r.sub = std::make_unique<dds::Subscription>(participant, t->name, t->descriptor, t->reader_qos());
    waitset.attach(r.sub->reader(), r.ros_name);
    rec.push_back(std::move(r));
  }

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto elapsed_ns = [&] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start).count();
  };
  const TimeNs duration_ns = from_seconds(a.duration_s);
  std::uint64_t total = 0;
  std::vector<std::uint8_t> scratch;
  std::fprintf(stderr, "recording %zu topic(s) to %s (Ctrl-C stops)\n", rec.size(), a.out.c_str());
  const auto take_all = [&] {
    for (Recorded& r : rec) {
      const std::size_t max = a.count > 0 ? static_cast<std::size_t>(a.count - total) : 256;
      if (max == 0) break;
      const std::size_t n = dds::take_serialized(
          r.sub->reader(),
          [&](std::span<const std::uint8_t> bytes, const dds_sample_info_t& info) {
            const std::uint64_t now = realtime_ns();
            const std::uint64_t pub =
                info.source_timestamp > 0 ? static_cast<std::uint64_t>(info.source_timestamp) : now;
            writer.write(r.channel, r.sequence++, now, pub, bytes);
          },
          scratch, max);
      r.count += n;
      total += n;
    }
  };
  const auto count_reached = [&] { return a.count > 0 && total >= a.count; };
  while (!g_stop.load() && !count_reached()) {
    TimeNs slice = 100 * kNsPerMs;
    if (duration_ns > 0) {
      const TimeNs left = duration_ns - elapsed_ns();
      if (left <= 0) break;
      slice = std::min(slice, left);
    }
    if (waitset.wait(slice)) take_all();
  }
  if (!count_reached()) take_all();  // what arrived before the stop (Ctrl-C, --duration) is kept
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  writer.close();
  const double secs = static_cast<double>(elapsed_ns()) * 1e-9;
  std::printf("recorded %llu samples in %.3f s (%.0f samples/s) to %s (%llu bytes)\n",
              static_cast<unsigned long long>(total), secs, secs > 0 ? static_cast<double>(total) / secs : 0.0,
              a.out.c_str(), static_cast<unsigned long long>(writer.stats().file_bytes));
  for (const Recorded& r : rec) {
    std::printf("  %-32s %-36s %llu\n", r.ros_name.c_str(), std::string(r.info->ros_type).c_str(),
                static_cast<unsigned long long>(r.count));
  }
  std::fflush(stdout);
}

const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<RecordArgs>();
  CLI::App* cmd = app.add_subcommand("record", "record DDS topics into an MCAP file (like ros2 bag record)");
  cmd->add_option("topics", a->topics,
                  "topics, e.g. joint_states /diagnostics terrain/grid_map (`regolith echo --list`)");
  cmd->add_option("--out,-o", a->out, "MCAP file to write")->required();
  cmd->add_flag("--all,-a", a->all, "record every known topic");
  cmd->add_option("--duration", a->duration_s, "stop after this many seconds")->check(regolith::cli::positive());
  cmd->add_option("--count,-n", a->count, "stop after N samples in total");
  cmd->add_option("--domain", a->domain, "DDS domain id (default: $ROS_DOMAIN_ID, else 0)")->check(CLI::Range(0, 232));
  cmd->add_option("--namespace", a->ns, "robot namespace of relative topic names");
  auto* z = cmd->add_flag("--zstd", a->zstd, "zstd-compressed chunks (the default)");
  auto* nc = cmd->add_flag("--no-compression", a->no_compression, "uncompressed chunks");
  z->excludes(nc);
  cmd->callback([a] { run_record(*a); });
});

}  // namespace
}  // namespace regolith::cli
