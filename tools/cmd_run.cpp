// regolith run: load a deployment, run its rate groups with a live summary until Ctrl-C or
// --duration. regolith config check: validate a deployment and print the resolved configuration.
#include <csignal>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include <unistd.h>

#include <spdlog/spdlog.h>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/params.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/watchdog.hpp"
#include "summary.hpp"
#ifdef REGOLITH_HAVE_DDS_RECORD
#include <yaml-cpp/yaml.h>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/recorder.hpp"
#include "regolith/record/hal_recorder.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "regolith/record/recording.hpp"
#endif
#ifdef REGOLITH_HAVE_LIVE
#include "regolith/live/dds_relay.hpp"
#include "regolith/live/web_root.hpp"
#endif

namespace regolith::cli {
namespace {

std::atomic<bool> g_stop{false};
extern "C" void on_signal(int) {
  g_stop.store(true);
}

Params load_config(const std::string& path) {
  if (path.empty()) return Params::load_string(embedded_mock_rover(), "<embedded>/config/mock_rover.yaml");
  return Params::load_file(path);
}

struct RunOptions {
  std::string config;
  /// `regolith replay`: the deployment as text (the recording's, devices turned into replays);
  /// used instead of `config` when not empty. `config` then only names it in messages.
  std::string config_yaml;
  TimeNs sim_start = kNsPerSec;  ///< simulated clock at start (replay: the recording's origin)
  TimeNs sim_ros_offset = 0;     ///< ROS time - simulated time (replay: the recording's offset)
  double duration_s = 0.0;
  bool sim_time = false;
  double summary_interval_s = 1.0;
  bool quiet = false;
  std::vector<std::string> wait_for;
  double wait_timeout_s = 30.0;
  std::string record;           ///< --record FILE (overrides record.file)
  std::string live;             ///< --live [ADDR:]PORT: Foxglove WebSocket server of the DDS topics
  std::string live_token_file;  ///< --live-token-file FILE (overrides live.token_file)
};

/// What `run` owns of a deployment: the `record:` and `live:` blocks with their command-line
/// overrides. Checked through Application's check_tool_blocks hook, before the rover description,
/// devices and components (a mock camera renders its frames at configure time): a wrong topic
/// name, listen address or token file is reported at once. `config check` runs the same checks.
struct ToolBlocks {
#ifdef REGOLITH_HAVE_DDS_RECORD
  std::vector<const dds::TopicInfo*> record_topics;  ///< record.topics (empty: every known topic)
#endif
#ifdef REGOLITH_HAVE_LIVE
  std::optional<live::FoxgloveServerOptions> live;  ///< the live server's options; empty: none
#endif

  void check(const runtime::RecordConfig& rc, const runtime::LiveConfig& lc, [[maybe_unused]] bool dds,
             const RunOptions& o) {
#ifdef REGOLITH_HAVE_DDS_RECORD
    if (!o.record.empty() && !dds)
      throw InputError(
          "run: --record: recording needs DDS, but the deployment has dds.enabled: false (record: "
          "records the DDS topics the deployment publishes)");
    record_topics.clear();
    for (const auto& name : rc.topics) {
      const dds::TopicInfo* t = dds::find_topic(name);
      if (t == nullptr)
        throw ConfigError(rc.where_topics + ": record.topics: unknown topic '" + name + "'; known topics:\n" +
                          dds::list_topics());
      record_topics.push_back(t);
    }
#else
    constexpr const char* kNoRecording = "this build has no MCAP recording (regolith_dds_record not built)";
    if (!o.record.empty()) throw InputError(std::string("run: --record: ") + kNoRecording);
    if (!rc.file.empty()) throw ConfigError(rc.where_file + ": record.file: " + kNoRecording);
#endif
#ifdef REGOLITH_HAVE_LIVE
    live.reset();
    if (o.live.empty() && !lc.enabled) return;
    if (!dds) throw InputError("run: --live: needs DDS, but the deployment has dds.enabled: false");
    live::FoxgloveServerOptions lo;
    try {
      live::parse_listen_address(o.live.empty() ? lc.listen : o.live, lo);
    } catch (const std::invalid_argument& e) {
      if (o.live.empty()) throw ConfigError(lc.where + ": live.listen: " + e.what());
      throw InputError(std::string("run: --live: ") + e.what());
    }
    lo.max_clients = static_cast<std::size_t>(lc.max_clients);
    lo.max_queue_bytes = static_cast<std::size_t>(lc.max_queue_mb * 1024 * 1024);
    lo.web_root = live::default_web_root();  // the built-in page on GET /
    const bool token_from_cli = !o.live_token_file.empty();
    const std::string token_file = token_from_cli ? o.live_token_file : lc.token_file;
    try {
      if (!token_file.empty()) lo.token = live::read_token_file(token_file);
    } catch (const std::invalid_argument& e) {
      if (token_from_cli) throw InputError(std::string("run: --live-token-file: ") + e.what());
      throw ConfigError(lc.token_where + ": live.token_file: " + e.what());
    }
    try {
      live::check_access(lo);
    } catch (const std::invalid_argument& e) {  // not loopback and no token
      if (o.live.empty()) throw ConfigError(lc.where + ": live.listen: " + e.what());
      throw InputError(std::string("run: --live: ") + e.what());
    }
    live = std::move(lo);
#else
    constexpr const char* kNoLive =
        "this build has no live server (configured with REGOLITH_WITH_LIVE=OFF or without websocketpp)";
    if (!o.live.empty()) throw InputError(std::string("run: --live: ") + kNoLive);
    if (lc.enabled) throw ConfigError(lc.where + ": live.enabled: " + kNoLive);
#endif
  }
};

#ifdef REGOLITH_HAVE_DDS_RECORD
/// The deployment file's text (the embedded mocked rover without --config) and its name.
std::pair<std::string, std::string> config_text(const RunOptions& o) {
  const std::string& path = o.config;
  if (!o.config_yaml.empty()) return {std::filesystem::path(path).filename().string(), o.config_yaml};
  if (path.empty()) return {"mock_rover.yaml", embedded_mock_rover()};
  // Already loaded (and so checked) as the deployment: read again, the same way, for the attachment.
  return {std::filesystem::path(path).filename().string(), read_text_file(path, "configuration file")};
}

std::string utc_now_iso() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  std::tm tm{};
  gmtime_r(&ts.tv_sec, &tm);
  char buf[64];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%S", &tm);
  char out[96];
  std::snprintf(out, sizeof out, "%s.%09ldZ", buf, static_cast<long>(ts.tv_nsec));
  return out;
}

/// `regolith run --record FILE` / the `record:` block: every DDS topic of the deployment (or
/// record.topics) into MCAP by a dds::DdsRecorder on the application's own participant, plus the
/// deployment file as an Attachment and a `regolith` Metadata record. Created before app->start()
/// so its readers have matched every writer before the first cycle.
std::unique_ptr<dds::DdsRecorder> make_recorder(runtime::Application& app, const RunOptions& o,
                                                const ToolBlocks& blocks) {
  const runtime::RecordConfig& rc = app.record_config();
  const std::string file = o.record.empty() ? rc.file : o.record;
  if (file.empty()) return nullptr;
  dds::DdsRecorderOptions ro;
  ro.topics = blocks.record_topics;
  ro.compression = rc.compression == "none" ? record::Compression::kNone : record::Compression::kZstd;
  ro.keep_all = o.sim_time;         // simulated time: every sample, however fast the rover runs
  ro.log_source_time = o.sim_time;  // ... on the simulated time line (the writers' source clock)
  ro.split_bytes = static_cast<std::uint64_t>(rc.split_mb * 1024.0 * 1024.0);
  ro.split_duration_ns = static_cast<std::uint64_t>(rc.split_s * 1e9);
#ifdef REGOLITH_VERSION
  const std::string version = REGOLITH_VERSION;
#else
  const std::string version = "unknown";
#endif
  ro.library = "regolith run " + version;
  // A full disk (or any write error) stops the recording, never the rover: said once, at once.
  ro.on_error = [](const std::string& why) {
    spdlog::error("record: {}: recording stopped; the deployment keeps running", why);
  };
  std::unique_ptr<dds::DdsRecorder> rec;
  try {
    rec = std::make_unique<dds::DdsRecorder>(*app.dds(), file, ro);
  } catch (const std::runtime_error& e) {  // cannot create the file, or not even its header fits
    throw InputError(std::string("run: --record: ") + e.what());
  }
  const auto [name, text] = config_text(o);
  rec->add_attachment(name, "application/yaml", text);
  rec->add_metadata("regolith", {{"deployment", app.name()},
                                 {"version", version},
                                 {"sim_time", o.sim_time ? "true" : "false"},
                                 {"start_time", utc_now_iso()},
                                 {"config", o.config.empty() ? "<embedded>/config/mock_rover.yaml" : o.config}});
  std::vector<std::string> topics;
  for (const auto& c : rec->counts()) topics.push_back(c.ros_name);
  if (!app.dds()->wait_for_readers(topics, 10 * kNsPerSec))
    spdlog::warn("record: not every writer matched the recorder within 10 s");
  // Nothing runs yet: a file that cannot even take its header is refused before the start.
  if (const std::string err = rec->error(); !err.empty()) throw InputError("run: --record: " + err);
  spdlog::info("recording {} topic(s) to {}", rec->topic_count(), file);
  return rec;
}
#endif

#ifdef REGOLITH_HAVE_DDS_RECORD
/// `regolith replay FILE.mcap`: the deployment recorded in FILE (its YAML attachment, or
/// `config_override`) with every device turned into a `replay` backend of FILE and no record.file
/// (a replay never writes over its own input). Returns the YAML text; `name` names it.
std::string replay_deployment(const std::string& file, const std::string& config_override, std::string& name) {
  const std::string abs = std::filesystem::absolute(file).string();
  std::string text;
  if (!config_override.empty()) {
    try {
      text = read_text_file(config_override, "configuration file");
    } catch (const InputError& e) {
      throw InputError(std::string("replay: --config: ") + e.what());
    }
    name = config_override;
  } else {
    const record::RecordedDeployment d = record::recorded_deployment(abs);
    text = d.text;
    name = d.name;
    if (text.empty())
      throw InputError(file + ": no deployment attached (files of `regolith run --record` carry it; give --config)");
  }
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(name + ": " + e.what());
  }
  if (!root.IsMap()) throw InputError(name + ": not a deployment (no mapping at the top)");
  YAML::Node devices = root["devices"];
  for (const char* section : {"cameras", "encoders", "imus"}) {
    YAML::Node sec = devices[section];
    if (!sec || !sec.IsMap()) continue;
    for (auto it = sec.begin(); it != sec.end(); ++it) {
      YAML::Node r(YAML::NodeType::Map);
      r["backend"] = "replay";
      r["file"] = abs;
      it->second = r;
    }
  }
  if (root["record"] && root["record"].IsMap()) root["record"].remove("file");
  YAML::Emitter out;
  out << root;
  return out.c_str();
}

/// The time frame of the HAL recording of `file` (`regolith_hal` / `regolith_hal_end` metadata).
struct RecordedTimes {
  TimeNs origin = -1, end = -1, ros_offset = 0;
  bool cut_short = false;  // no end record: `end` is the last readable device sample
};
RecordedTimes recorded_times(const std::string& file) {
  RecordedTimes t;
  // Over the files of a split recording (the end is in the last one).
  bool first = true;
  for (const std::filesystem::path& path : record::mcap_recording_files(file)) {
    record::McapReader reader(path);
    const record::HalRecordingInfo h = record::hal_recording_info(reader.info(), path.string());
    if (first) {
      t = {h.origin_ns, h.end_ns, h.ros_offset_ns};
      first = false;
    } else {
      t.end = std::max(t.end, h.end_ns);
    }
  }
  if (t.origin >= 0 && t.end <= t.origin) {
    // Cut off before its end record (power loss, full disk): as long as its last readable device
    // sample.
    for (const std::filesystem::path& path : record::mcap_recording_files(file)) {
      record::McapReader reader(path);
      t.end = std::max(t.end, record::last_hal_stamp(reader));
    }
    t.cut_short = t.end > t.origin;
  }
  return t;
}

/// The samples each topic of `a` has in `b`, byte for byte (topics under /hal and the ones that
/// carry measured times or logs - /diagnostics, /rosout, /clock - are left out). Prints one line
/// per topic; returns the number of topics that differ.
int compare_recordings(const std::string& a, const std::string& b) {
  auto load = [](const std::string& first) {
    // Every file of a split recording, in order (no message is in two files).
    std::map<std::string, std::vector<std::vector<std::uint8_t>>> by_topic;
    for (const std::filesystem::path& f : record::mcap_recording_files(first)) {
      record::McapReader r(f);
      for (const auto& [id, ch] : r.info().channels) {
        const std::string& t = ch.topic;
        const bool skip = t.rfind("/hal/", 0) == 0 || t.find("diagnostics") != std::string::npos ||
                          t.find("rosout") != std::string::npos || t == "/clock";
        if (!skip) by_topic[t];
      }
      (void)r.for_each_message([&](const record::MessageView& m) {
        auto it = by_topic.find(m.channel.topic);
        if (it != by_topic.end()) it->second.emplace_back(m.data.begin(), m.data.end());
      });
    }
    return by_topic;
  };
  const auto ta = load(a), tb = load(b);
  // Camera previews are drawn and encoded by a worker thread outside the rate groups, which skips a
  // frame while it is still busy with an earlier one and draws the hazard overlay only when the
  // grid of the same frame is still the newest: on a loaded machine a replay can differ there
  // without any real-time output differing. They are compared and shown, but do not fail it.
  const auto best_effort = [](const std::string& t) { return t.find("/preview/") != std::string::npos; };
  int differ = 0;
  std::printf("%-34s %8s %8s %10s  %s\n", "topic", "recorded", "replayed", "identical", "first difference");
  for (const auto& [topic, sa] : ta) {
    auto it = tb.find(topic);
    const std::vector<std::vector<std::uint8_t>> none;
    const auto& sb = it == tb.end() ? none : it->second;
    std::size_t same = 0;
    long first = -1;
    for (std::size_t i = 0; i < std::min(sa.size(), sb.size()); ++i) {
      if (sa[i] == sb[i]) {
        ++same;
      } else if (first < 0) {
        first = static_cast<long>(i);
      }
    }
    const bool ok = sa.size() == sb.size() && same == sa.size();
    if (!ok && !best_effort(topic)) ++differ;
    const std::string where = ok ? "-" : first >= 0 ? "sample " + std::to_string(first) : "count";
    std::printf("%-34s %8zu %8zu %10zu  %s%s\n", topic.c_str(), sa.size(), sb.size(), same, where.c_str(),
                !ok && best_effort(topic) ? " (best effort: not counted)" : "");
  }
  return differ;
}
#endif

void run(const RunOptions& o) {
  runtime::AppOptions ao{.sim_time = o.sim_time,
                         .wait_for = o.wait_for,
                         .wait_timeout = from_seconds(o.wait_timeout_s),
                         .sim_start = o.sim_start,
                         .sim_ros_offset = o.sim_ros_offset};
#ifdef REGOLITH_HAVE_DDS_RECORD
  // Every device is wrapped for the HAL recording; the wrappers only forward unless recording.
  // Simulated time: lossless (a full ring waits for the writer) so a replay sees every frame.
  record::HalRecorder hal_recorder({.lossless = o.sim_time, .sim_ros_offset = o.sim_ros_offset});
  ao.wrap_device = [&](std::unique_ptr<hal::Device> d) { return hal_recorder.wrap(std::move(d)); };
#endif
  ToolBlocks blocks;
  ao.check_tool_blocks = [&](const runtime::RecordConfig& rc, const runtime::LiveConfig& lc, bool dds) {
    blocks.check(rc, lc, dds, o);
  };
  auto app = runtime::Application::load(
      o.config_yaml.empty() ? load_config(o.config) : Params::load_string(o.config_yaml, o.config), ao);
  std::signal(SIGINT, on_signal);
  std::signal(SIGTERM, on_signal);
  spdlog::info("deployment '{}': {} rate groups, {} components{}", app->name(), app->view().groups.size(),
               app->view().components.size(), o.sim_time ? " (simulated time)" : "");
  // Under systemd (Type=notify): READY=1 once every rate group has cycled, WATCHDOG=1 only while
  // every critical component is healthy (see runtime/watchdog.hpp). Outside systemd: no-ops.
  runtime::SystemdNotifier notifier;
  auto& health = app->context().channel<runtime::HealthSnapshot>("health/snapshot");
#ifdef REGOLITH_HAVE_DDS_RECORD
  std::unique_ptr<dds::DdsRecorder> recorder = make_recorder(*app, o, blocks);
  if (recorder) recorder->start();
  const bool record_hal = recorder && app->record_config().hal;
  if (record_hal) hal_recorder.start(*recorder, app->clock());
#endif
#ifdef REGOLITH_HAVE_LIVE
  // `--live`: the same server as `regolith live`, on the application's own participant (its own
  // threads: the relay only reads DDS).
  std::unique_ptr<live::DdsRelay> relay;
  if (blocks.live) {
    const live::FoxgloveServerOptions& lo = *blocks.live;
    relay = std::make_unique<live::DdsRelay>(*app->dds(), lo);  // std::runtime_error when the port cannot be bound
    relay->start();
    spdlog::info("live: Foxglove WebSocket server on ws://{}:{}, page http://{}:{}/", lo.address,
                 relay->server().port(), lo.address, relay->server().port());
  }
#endif
  app->start();

  Summary summary(*app, isatty(STDOUT_FILENO) != 0 && !o.quiet);
  const TimeNs duration = o.duration_s > 0 ? from_seconds(o.duration_s) : 0;
  const TimeNs t_end = duration > 0 ? app->clock().now() + duration : INT64_MAX;
  const TimeNs wall_interval = from_seconds(o.summary_interval_s);
  TimeNs next_print = monotonic_now() + wall_interval;
  // Run in slices so the summary is produced on this (non real-time) thread. Under --sim-time a
  // slice is one simulated second.
  while (!g_stop.load() && app->clock().now() < t_end) {
    const TimeNs slice = std::min<TimeNs>(app->sim_time() ? kNsPerSec : 100 * kNsPerMs, t_end - app->clock().now());
    app->run(slice, g_stop);
    {
      const auto snapshot = health.acquire();
      notifier.update(app->view(), snapshot ? &*snapshot : nullptr, app->clock().now());
    }
    if (!o.quiet && monotonic_now() >= next_print) {
      summary.print(std::cout);
      next_print = monotonic_now() + wall_interval;
    }
  }
  notifier.stopping();
  app->stop();
#ifdef REGOLITH_HAVE_LIVE
  if (relay) {
    relay->stop();
    const auto st = relay->server().stats();
    std::printf("live: %llu messages sent, %llu clients, %llu dropped (slow), %llu refused, %llu without the token\n",
                static_cast<unsigned long long>(st.messages_sent), static_cast<unsigned long long>(st.accepted),
                static_cast<unsigned long long>(st.dropped_slow), static_cast<unsigned long long>(st.refused),
                static_cast<unsigned long long>(st.unauthorized));
  }
#endif
#ifdef REGOLITH_HAVE_DDS_RECORD
  hal_recorder.stop();             // the devices' last inputs, before the file is closed
  if (recorder) recorder->stop();  // takes what is still in flight, then summary + footer
#endif
  if (!o.quiet) summary.print(std::cout, /*final=*/true);
#ifdef REGOLITH_HAVE_DDS_RECORD
  if (recorder) {
    std::printf("recorded %llu samples on %zu topics to %s (%llu bytes; recorder thread CPU %.3f s)\n",
                static_cast<unsigned long long>(recorder->total()), recorder->topic_count(), recorder->path().c_str(),
                static_cast<unsigned long long>(recorder->file_bytes()),
                static_cast<double>(recorder->thread_cpu_ns()) * 1e-9);
    if (const auto files = recorder->files(); files.size() > 1) {
      std::printf("  split into %zu files:", files.size());
      for (const auto& f : files) std::printf(" %s", f.filename().c_str());
      std::printf("\n");
    }
    for (const auto& t : recorder->counts())
      std::printf("  recorded %-32s %llu\n", t.ros_name.c_str(), static_cast<unsigned long long>(t.count));
    if (record_hal) {
      for (const auto& d : hal_recorder.counts())
        std::printf("  recorded device %-8s %-12s %llu messages, %llu dropped\n", d.kind.c_str(), d.id.c_str(),
                    static_cast<unsigned long long>(d.recorded), static_cast<unsigned long long>(d.dropped));
    }
    std::fflush(stdout);
    // The run went on to its end; the recording did not: say so and fail the command.
    if (const std::string err = recorder->error(); !err.empty())
      throw std::runtime_error("run: the recording stopped early: " + err + "; " + std::to_string(recorder->lost()) +
                               " later samples not recorded (the file keeps every chunk written before)");
  }
#endif
}

const bool registered = add_command([](CLI::App& app) {
  auto opts = std::make_shared<RunOptions>();
  CLI::App* cmd = app.add_subcommand("run", "run a deployment (default: the embedded mocked rover)");
  cmd->add_option("--config,-c", opts->config, "deployment YAML (default: embedded config/mock_rover.yaml)");
  cmd->add_option("--duration,-d", opts->duration_s, "stop after this many seconds (of simulated time with --sim-time)")
      ->check(regolith::cli::positive());
  cmd->add_flag("--sim-time", opts->sim_time, "simulated clock: run in lockstep as fast as the CPU allows");
  cmd->add_option("--summary-interval", opts->summary_interval_s, "seconds between live summaries")
      ->check(regolith::cli::positive());
  cmd->add_flag("--quiet,-q", opts->quiet, "no live summary");
  cmd->add_option("--wait-for", opts->wait_for,
                  "before starting, wait for a subscriber on this DDS topic (repeatable)");
  cmd->add_option("--wait-timeout", opts->wait_timeout_s, "seconds to wait for --wait-for subscribers")
      ->check(regolith::cli::non_negative());
  cmd->add_option("--record", opts->record,
                  "record every DDS topic of the deployment into this MCAP file (overrides record.file)");
  cmd->add_option("--live", opts->live,
                  "serve the DDS topics to Foxglove Studio over the Foxglove WebSocket protocol on [ADDR:]PORT "
                  "(e.g. 8765 = 127.0.0.1:8765)");
  cmd->add_option("--live-token-file", opts->live_token_file,
                  "access token file (mode 0600) the live view's clients must present (`?token=`); needed to listen "
                  "on an address other than loopback (overrides live.token_file)");
  cmd->callback([opts] { run(*opts); });

#ifdef REGOLITH_HAVE_DDS_RECORD
  auto ropts = std::make_shared<RunOptions>();
  auto rfile = std::make_shared<std::string>();
  auto rconfig = std::make_shared<std::string>();
  auto realtime = std::make_shared<bool>(false);
  auto compare = std::make_shared<bool>(false);
  CLI::App* replay = app.add_subcommand(
      "replay", "run a recorded deployment again on the inputs its devices delivered (a `run --record` file)");
  replay->add_option("file", *rfile, "MCAP file written by `regolith run --record`")->required();
  replay->add_option("--config,-c", *rconfig, "deployment YAML to run instead of the recorded one (devices replaced)");
  replay->add_option("--duration,-d", ropts->duration_s, "seconds to run (default: as long as the recording)")
      ->check(regolith::cli::positive());
  replay->add_flag("--realtime", *realtime, "pace by the wall clock (default: simulated time, as fast as possible)");
  replay->add_flag("--quiet,-q", ropts->quiet, "no live summary");
  replay->add_option("--record", ropts->record, "record the replay (DDS topics and devices) into this MCAP file");
  replay->add_flag("--compare", *compare,
                   "compare every published topic of the replay with the recording, sample by sample (needs "
                   "--record; exit status 1 when any differs)");
  replay->add_option("--live", ropts->live, "serve the replay to Foxglove Studio on [ADDR:]PORT");
  replay->add_option("--live-token-file", ropts->live_token_file,
                     "access token file (mode 0600) for the live view; needed off loopback");
  replay->callback([ropts, rfile, rconfig, realtime, compare] {
    RunOptions o = *ropts;
    if (*compare && o.record.empty())
      throw InputError("replay: --compare needs --record FILE (the replay's recording)");
    if (!o.record.empty() && std::filesystem::exists(o.record) && std::filesystem::exists(*rfile) &&
        std::filesystem::equivalent(o.record, *rfile))
      throw InputError("replay: --record " + o.record + " is the recording being replayed");
    o.sim_time = !*realtime;
    o.config_yaml = replay_deployment(*rfile, *rconfig, o.config);
    // On simulated time the replay starts at the recorded clock value and ROS time offset: its
    // stamps are the recording's (a real-time recording's too).
    const RecordedTimes times = recorded_times(*rfile);
    if (times.origin >= 0) {
      o.sim_start = times.origin;
      o.sim_ros_offset = times.ros_offset;
    }
    if (o.duration_s <= 0) {
      if (times.end <= times.origin)
        throw InputError(*rfile +
                         ": the recording's length is unknown (no regolith_hal_end and no readable device "
                         "sample); give --duration");
      o.duration_s = to_seconds(times.end - times.origin);
      if (times.cut_short)
        spdlog::warn("{}: no end record (the recording was cut short): replaying its readable part, {:.3f} s", *rfile,
                     o.duration_s);
    }
    run(o);
    if (*compare) {
      const int differ = compare_recordings(*rfile, o.record);
      std::printf("%s\n", differ == 0 ? "replay identical to the recording" : "replay differs from the recording");
      std::fflush(stdout);
      if (differ != 0) throw CLI::RuntimeError(1);
    }
  });
#endif

  CLI::App* config = group(app, "config", "deployment configuration tools");
  auto files = std::make_shared<std::vector<std::string>>();
  auto dot = std::make_shared<bool>(false);
  CLI::App* check = config->add_subcommand(
      "check",
      "validate deployments; for one, print the resolved configuration and the data-flow graph, for several "
      "one line each");
  check->add_option("files", *files, "deployment YAML files (default: the embedded mocked rover)");
  check->add_flag("--dot", *dot, "print only the data-flow graph, in Graphviz dot (| dot -Tsvg > flow.svg)");
  check->callback([files, dot] {
    // The record: and live: blocks as `run` checks them (no command-line overrides here; DDS is
    // not started by `config check`, so not asked for).
    auto load = [](const std::string& file) {
      ToolBlocks blocks;
      return runtime::Application::load(
          load_config(file), {.sim_time = true,
                              .enable_dds = false,
                              .open_devices = false,
                              .check_tool_blocks = [&](const runtime::RecordConfig& rc, const runtime::LiveConfig& lc,
                                                       bool) { blocks.check(rc, lc, /*dds=*/true, RunOptions{}); }});
    };
    auto ok_line = [](const std::string& file, const runtime::Application& a) {
      return "# " + (file.empty() ? std::string("<embedded>/config/mock_rover.yaml") : file) + ": OK (" +
             std::to_string(a.view().groups.size()) + " rate groups, " + std::to_string(a.view().components.size()) +
             " components)\n";
    };
    if (files->size() <= 1) {  // one deployment: its errors as any command's (exit 2), or everything resolved
      const std::string file = files->empty() ? std::string() : files->front();
      auto loaded = load(file);
      if (*dot) {
        loaded->dataflow().print_dot(std::cout);
        return;
      }
      std::cout << ok_line(file, *loaded);
      print_resolved(std::cout, loaded->resolved());
      loaded->dataflow().print(std::cout);
      return;
    }
    if (*dot)
      throw InputError("config check: --dot takes one deployment (" + std::to_string(files->size()) + " given)");
    // Several (`regolith config check config/*.yaml`): every file is checked, each error said with
    // its file, exit 2 when any has one.
    std::size_t failed = 0;
    for (const std::string& file : *files) {
      try {
        std::cout << ok_line(file, *load(file)) << std::flush;
      } catch (const std::exception& e) {  // ConfigError / InputError / FieldError: each names its file
        ++failed;
        const std::string what = e.what();
        spdlog::error("{}", what.find(file) == std::string::npos ? file + ": " + what : what);
      }
    }
    if (failed > 0) {
      spdlog::error("config check: {} of {} deployments have errors", failed, files->size());
      throw CLI::RuntimeError(kExitConfig);
    }
  });
});

}  // namespace
}  // namespace regolith::cli
