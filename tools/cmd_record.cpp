// regolith record TOPIC... --out FILE.mcap: record regolith's DDS topics from a separate process
// into an MCAP file, like `ros2 bag record` (record/README.md), with dds::DdsRecorder (the same
// class `regolith run --record` uses). Samples are kept as the CDR bytes
// that were on the wire (dds_takecdr), one ros2msg Schema per ROS type (the .msg definitions of
// msgs/ros2, regolith::msgs::ros2msg_definition), one cdr Channel per topic (its ROS name, e.g.
// /rover1/joint_states); log_time = receive time, publish_time = the DDS source timestamp (both
// wall-clock ns since 1970; with --use-sim-time log_time = the source timestamp too, which a
// `regolith run --sim-time` sets to its simulated ROS time, or the newest /clock for a writer on
// wall time: dds::sim_log_time). Stops on Ctrl-C / SIGTERM,
// --duration or --count and always closes the file (summary + footer).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <spdlog/spdlog.h>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/recorder.hpp"
#include "regolith/dds/topics.hpp"

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
  int domain = -1;  // -1: $ROS_DOMAIN_ID (read when the command runs: a bad value is a usage error), else 0
  std::string ns = "rover1";
  bool all = false;
  bool zstd = false;
  bool no_compression = false;
  bool use_sim_time = false;
  double split_mb = 0.0, split_s = 0.0;
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
  dds::Participant participant(dds::ParticipantConfig{dds::resolve_domain_id(a.domain), a.ns});
  dds::DdsRecorderOptions ro;
  ro.topics = wanted;
  ro.compression = a.no_compression ? record::Compression::kNone : record::Compression::kZstd;
  ro.max_samples = a.count;
  ro.log_source_time = a.use_sim_time;
  ro.split_bytes = static_cast<std::uint64_t>(a.split_mb * 1024.0 * 1024.0);
  ro.split_duration_ns = static_cast<std::uint64_t>(a.split_s * 1e9);
#ifdef REGOLITH_VERSION
  ro.library = std::string("regolith record ") + REGOLITH_VERSION;
#else
  ro.library = "regolith record";
#endif
  ro.on_error = [](const std::string& why) { spdlog::error("record: {}: recording stopped", why); };
  participant.announce_node(tool_node_name("record"));  // a node with one subscription per recorded topic
  dds::DdsRecorder recorder(participant, a.out, ro);    // throws when the file cannot be created

  using Clock = std::chrono::steady_clock;
  const auto start = Clock::now();
  const auto elapsed_ns = [&] {
    return std::chrono::duration_cast<std::chrono::nanoseconds>(Clock::now() - start).count();
  };
  const TimeNs duration_ns = from_seconds(a.duration_s);
  std::fprintf(stderr, "recording %zu topic(s) to %s (Ctrl-C stops)\n", recorder.topic_count(), a.out.c_str());
  recorder.start();
  while (!g_stop.load() && !recorder.done() && recorder.error().empty()) {
    TimeNs slice = 20 * kNsPerMs;
    if (duration_ns > 0) {
      const TimeNs left = duration_ns - elapsed_ns();
      if (left <= 0) break;
      slice = std::min(slice, left);
    }
    std::this_thread::sleep_for(std::chrono::nanoseconds(slice));
  }
  std::signal(SIGINT, SIG_DFL);
  std::signal(SIGTERM, SIG_DFL);
  recorder.stop();  // what arrived before the stop (Ctrl-C, --duration) is kept; summary + footer
  const double secs = static_cast<double>(elapsed_ns()) * 1e-9;
  const std::uint64_t total = recorder.total();
  std::printf("recorded %llu samples in %.3f s (%.0f samples/s) to %s (%llu bytes)\n",
              static_cast<unsigned long long>(total), secs, secs > 0 ? static_cast<double>(total) / secs : 0.0,
              a.out.c_str(), static_cast<unsigned long long>(recorder.file_bytes()));
  if (const auto files = recorder.files(); files.size() > 1) {
    std::printf("  split into %zu files:", files.size());
    for (const auto& f : files) std::printf(" %s", f.filename().c_str());
    std::printf("\n");
  }
  for (const auto& c : recorder.counts()) {
    std::printf("  %-32s %-36s %llu\n", c.ros_name.c_str(), c.ros_type.c_str(),
                static_cast<unsigned long long>(c.count));
  }
  if (const std::uint64_t n = recorder.logged_at_clock(); n > 0) {
    std::printf("  %llu sample(s) of writers on wall time logged at the newest /clock\n",
                static_cast<unsigned long long>(n));
  }
  std::fflush(stdout);
  if (const std::string err = recorder.error(); !err.empty())  // disk full, file too large, I/O error
    throw std::runtime_error("record: " + err + " (the file keeps every chunk written before)");
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
  cmd->add_flag("--use-sim-time", a->use_sim_time,
                "log each sample on the simulated time line: at its DDS source time (the simulated ROS time of a "
                "`regolith run --sim-time`), or at the newest /clock when its writer stamps wall time (a ROS 2 "
                "node) (default: when it was received, wall clock)");
  cmd->add_option("--split-size", a->split_mb, "start a new file (<stem>_001.mcap, ...) after about this many MiB")
      ->check(CLI::Range(0.01, 1e6));
  cmd->add_option("--split-duration", a->split_s, "start a new file after this many seconds of messages")
      ->check(regolith::cli::positive());
  cmd->callback([a] { run_record(*a); });
});

}  // namespace
}  // namespace regolith::cli
