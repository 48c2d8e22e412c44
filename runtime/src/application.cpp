#include "regolith/runtime/application.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <memory>
#include <set>
#include <thread>
#include <type_traits>
#include <vector>

#include <spdlog/spdlog.h>

#include "regolith/hal/plausible_encoders.hpp"
#include "regolith/hal/plausible_imu.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/hal/stamp_checked_camera.hpp"
#include "regolith/runtime/dds_hooks.hpp"
#include "regolith/runtime/event_log.hpp"

namespace regolith::runtime {

Application::~Application() {
  stop();
}

Clock& Application::clock() {
  return executor_->clock();
}

namespace {

// `record:` — the in-process recording of `regolith run` (the tool records; read here so `config
// check` lists it). `dds_missing`: DDS was asked for but is off in the deployment.
RecordConfig read_record_config(Params rec, bool dds_missing) {
  RecordConfig r;
  r.file = rec.get<std::string>("file", "",
                                {.doc = "MCAP file recording every DDS sample the deployment publishes (empty = none; "
                                        "`regolith run --record FILE` overrides)"});
  r.topics = rec.get<std::vector<std::string>>(
      "topics", {}, {.doc = "topics to record (names of `regolith echo --list`; empty = every known topic)"});
  r.compression =
      rec.get<std::string>("compression", "zstd", {.choices = {"zstd", "none"}, .doc = "MCAP chunk compression"});
  r.hal = rec.get<bool>("hal", true,
                        {.doc = "also record what the devices delivered (camera frames, encoder and IMU samples) so "
                                "`regolith replay` can run the deployment again on them"});
  r.split_mb =
      rec.get<double>("split_mb", 0.0,
                      {.unit = "MiB",
                       .min = 0.0,
                       .max = 1e6,
                       .doc = "start a new file (<stem>_001.mcap, ...) after about this many MiB (0 = never)"});
  if (r.split_mb > 0.0 && r.split_mb < 0.01) rec.fail("split_mb", "must be 0 (never) or >= 0.01 MiB");
  r.split_s = rec.get<double>(
      "split_s", 0.0,
      {.unit = "s", .min = 0.0, .max = 1e7, .doc = "start a new file after this many seconds of messages (0 = never)"});
  r.where_topics = rec.where(rec.has("topics") ? "topics" : std::string_view{});
  r.where_file = rec.where(rec.has("file") ? "file" : std::string_view{});
  if (dds_missing && !r.file.empty())
    rec.fail("file",
             "recording needs DDS: set dds.enabled: true (record: records the DDS topics the "
             "deployment publishes)");
  rec.finish();
  return r;
}

// `live:` — the Foxglove WebSocket server and page of `regolith run` (the tool serves; read here).
LiveConfig read_live_config(Params live, const std::string& config_dir, bool dds_missing) {
  LiveConfig l;
  l.enabled = live.get<bool>("enabled", false,
                             {.doc = "serve every DDS topic over the Foxglove WebSocket protocol and the built-in page "
                                     "(`regolith run --live [ADDR:]PORT` enables it too)"});
  l.listen = live.get<std::string>("listen", "127.0.0.1:8765",
                                   {.doc = "[ADDR:]PORT to listen on (0.0.0.0 = every interface)"});
  l.max_clients =
      live.get<int>("max_clients", 8, {.min = 1, .max = 1000, .doc = "connections beyond this are refused"});
  l.max_queue_mb = live.get<double>("max_queue_mb", 8.0,
                                    {.unit = "MiB",
                                     .min = 0.0,
                                     .max = 4096.0,
                                     .min_exclusive = true,
                                     .doc = "per-client send queue; a client whose queue would exceed it is dropped"});
  l.token_file = live.get<std::string>(
      "token_file", "",
      {.doc = "file (mode 0600) holding the access token clients must present (`?token=`); needed to listen on an "
              "address other than loopback (relative paths: from the config's directory)"});
  if (!l.token_file.empty() && std::filesystem::path(l.token_file).is_relative())
    l.token_file = (std::filesystem::path(config_dir) / l.token_file).string();
  l.token_where = live.where(live.has("token_file") ? "token_file" : std::string_view{});
  l.where = live.where(live.has("listen") ? "listen" : std::string_view{});
  if (dds_missing && l.enabled)
    live.fail("enabled", "the live view needs DDS: set dds.enabled: true (it serves the DDS topics)");
  live.finish();
  return l;
}

// `devices:` — every device of every kind (devices.<section>.<name> -> BackendRegistry::make<Kind>),
// each behind the checks every backend of its kind gets, added to the context.
void load_devices(Params devices, Context& ctx, const AppOptions& opts, const std::string& config_dir) {
  auto& reg = hal::BackendRegistry::instance();
  auto load_kind = [&]<class Kind>(const char* section) {
    Params sec = devices.child(section);
    std::uint16_t index = 0;
    for (const auto& name : sec.keys()) {
      Params p = sec.child(name);
      hal::DeviceContext dc{name, index++, &ctx.clock(), config_dir, opts.open_devices, &ctx.rover()};
      std::unique_ptr<hal::Device> d = reg.make<Kind>(p, dc);
      p.finish();
      // Encoder samples are checked for plausibility (finite, no faster turn than the wheel can)
      // before anything reads them: one check for every backend.
      if constexpr (std::is_same_v<Kind, hal::WheelEncoders>) {
        auto enc = std::unique_ptr<hal::WheelEncoders>(static_cast<hal::WheelEncoders*>(d.release()));
        std::vector<double> rates;
        for (const std::string& wheel : enc->wheel_names()) {
          double r = hal::PlausibleEncoders::kDefaultMaxRateRadS;
          for (const Wheel& w : ctx.rover().wheels)
            if (w.name == wheel && (w.encoders.empty() || w.encoders == name)) r = w.max_rate_rad_s;
          rates.push_back(r);
        }
        d = std::make_unique<hal::PlausibleEncoders>(std::move(enc), std::move(rates));
      }
      // Frames stamped after they are read (a device clock off the process clock) are withheld
      // and counted: one check for every camera backend.
      if constexpr (std::is_same_v<Kind, hal::Camera>)
        d = std::make_unique<hal::StampCheckedCamera>(
            std::unique_ptr<hal::Camera>(static_cast<hal::Camera*>(d.release())), ctx.clock());
      // IMU samples beyond what an IMU can report (a damaged packet) are skipped and counted.
      if constexpr (std::is_same_v<Kind, hal::Imu>)
        d = std::make_unique<hal::PlausibleImu>(std::unique_ptr<hal::Imu>(static_cast<hal::Imu*>(d.release())),
                                                ctx.clock());
      if (opts.wrap_device && opts.open_devices) d = opts.wrap_device(std::move(d));
      ctx.add_device(name, std::move(d));
    }
    sec.finish();
  };
  load_kind.operator()<hal::Camera>("cameras");
  load_kind.operator()<hal::WheelEncoders>("encoders");
  load_kind.operator()<hal::Imu>("imus");
  devices.finish();
}

// Every device the rover description names (its cameras, the wheels' encoders, the IMU) is one
// of the deployment's devices.
void check_rover_devices(Params& root, Context& ctx) {
  for (const auto& [name, cam] : ctx.rover().cameras) {
    if (ctx.find<hal::Camera>(name) == nullptr)
      throw ConfigError(cam.where + ": rover.cameras." + name + ": no camera device named '" + name +
                        "' in devices.cameras (the description is keyed by device name)");
  }
  for (const auto& w : ctx.rover().wheels) {
    if (!w.encoders.empty() && ctx.find<hal::WheelEncoders>(w.encoders) == nullptr)
      throw ConfigError(root.where("rover") + ": rover.wheels[" + w.name + "].encoders: no encoder device named '" +
                        w.encoders + "' in devices.encoders");
  }
  if (!ctx.rover().imu.empty() && ctx.find<hal::Imu>(ctx.rover().imu) == nullptr)
    throw ConfigError(root.where("rover") + ": rover.imu: no IMU named '" + ctx.rover().imu + "' in devices.imus");
}

}  // namespace

Application::GroupPlan Application::read_rate_groups(Params& root) {
  GroupPlan plan;
  plan.params = root.child_list("rate_groups", true);
  if (plan.params.empty()) root.fail("rate_groups", "at least one rate group is required");
  std::set<std::string> group_names;
  for (auto& g : plan.params) {
    RateGroupConfig c;
    c.name = g.require<std::string>("name", {.doc = "rate group name"});
    if (!group_names.insert(c.name).second) g.fail("name", "duplicate rate group name '" + c.name + "'");
    const bool has_rate = g.has("rate_hz");
    const bool has_period = g.has("period_ms");
    if (has_rate == has_period) g.fail({}, "give exactly one of rate_hz or period_ms");
    if (has_rate) {
      const double hz = g.require<double>(
          "rate_hz", {.unit = "Hz", .min = 0.0, .max = 100000.0, .min_exclusive = true, .doc = "cycle rate"});
      c.period = static_cast<TimeNs>(std::llround(1e9 / hz));
    } else {
      const double ms =
          g.require<double>("period_ms", {.unit = "ms", .min = 0.0, .min_exclusive = true, .doc = "cycle period"});
      c.period = static_cast<TimeNs>(std::llround(ms * 1e6));
    }
    c.offset = static_cast<TimeNs>(std::llround(
        g.get<double>("offset_ms", 0.0, {.unit = "ms", .min = 0.0, .doc = "phase of the first release"}) * 1e6));
    c.priority = g.get<int>("priority", 0, {.min = 0, .max = 99, .doc = "SCHED_FIFO priority, 0 = normal"});
    c.cpu = g.get<int>("cpu", -1, {.min = -1, .max = 1023, .doc = "CPU affinity, -1 = any"});
    const std::string overrun =
        g.get<std::string>("overrun", "skip", {.choices = {"skip", "catch_up"}, .doc = "overrun policy"});
    c.overrun = overrun == "skip" ? OverrunPolicy::kSkip : OverrunPolicy::kCatchUp;
    c.members = g.require<std::vector<std::string>>("members", {.doc = "components, in execution order"});
    if (c.members.empty()) g.fail("members", "a rate group needs at least one member");
    for (const auto& m : c.members) {
      auto [it, inserted] = plan.member_of.emplace(m, c.name);
      if (!inserted) g.fail("members", "component '" + m + "' is already a member of rate group '" + it->second + "'");
    }
    g.finish();
    plan.configs.push_back(std::move(c));
  }
  return plan;
}

void Application::configure_components(Params comps, const GroupPlan& plan) {
  Context& ctx = *context_;
  for (const auto& name : comps.keys()) {
    Params p = comps.child(name);
    const std::string type = p.require<std::string>("type", {.doc = "component type"});
    auto c = ComponentRegistry::instance().make(p, type);
    c->name_ = name;
    c->type_ = type;
    c->configured_critical_ =
        p.get<bool>("critical", false, {.doc = "its health gates the systemd watchdog (stalled or failed: not fed)"});
    if (!plan.member_of.count(name)) p.fail({}, "component '" + name + "' is not a member of any rate group");
    ctx.begin_component(name, comps.where(name));
    c->configure(p, ctx);
    ctx.end_component();
    p.finish();
    c->state_.store(Lifecycle::kInactive);
    view_.components.push_back(c.get());
    components_.push_back(std::move(c));
  }
  comps.finish();
}

void Application::build_rate_groups(GroupPlan& plan) {
  std::map<std::string, Component*> by_name;
  std::vector<std::string> names;
  for (const auto& c : components_) {
    by_name[c->name_] = c.get();
    names.push_back(c->name_);
  }
  for (std::size_t gi = 0; gi < plan.configs.size(); ++gi) {
    auto& c = plan.configs[gi];
    std::vector<Component*> members;
    for (const auto& m : c.members) {
      auto it = by_name.find(m);
      if (it == by_name.end()) {
        std::string msg = "unknown component '" + m + "'";
        const std::string guess = did_you_mean(m, names);
        if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
        plan.params[gi].fail("members", msg);
      }
      members.push_back(it->second);
    }
    groups_.push_back(std::make_unique<RateGroup>(std::move(c), std::move(members)));
    view_.groups.push_back(groups_.back().get());
  }
}

std::unique_ptr<Application> Application::load(Params root, const AppOptions& opts) {
  std::unique_ptr<Application> app(new Application());
  app->opts_ = opts;
  app->resolved_ = root.sink();
  app->name_ = root.get<std::string>("name", "regolith", {.doc = "deployment name (diagnostics, logs)"});

  Params process = root.child("process");
  RealtimeOptions rt;
  rt.lock_memory = process.get<bool>("lock_memory", false, {.doc = "mlockall() before the rate groups start"});
  process.finish();

  if (opts.sim_time) {
    app->sim_clock_ = std::make_unique<SimClock>(opts.sim_start);
    app->executor_ = make_sim_executor(*app->sim_clock_);
  } else {
    app->executor_ = make_realtime_executor(rt);
  }
  const std::string config_dir = std::filesystem::path(root.file()).has_parent_path()
                                     ? std::filesystem::path(root.file()).parent_path().string()
                                     : ".";
  app->context_ = std::make_unique<Context>(app->executor_->clock(), config_dir);
  Context& ctx = *app->context_;
  app->view_.context = &ctx;
  ctx.set_system(&app->view_);

  // ---- DDS, and the tool's record: and live: blocks that need it ----
  Params dds = root.child("dds");
  if (opts.enable_dds) {
    app->dds_ = make_participant(dds, opts.sim_time);
    ctx.set_dds(app->dds_.get());
    if (app->dds_ && opts.sim_time) app->clock_pub_ = make_clock_publisher(*app->dds_);
  } else {
    declare_dds_params(dds);
  }
  dds.finish();
  const bool dds_missing = opts.enable_dds && !app->dds_;
  app->record_ = read_record_config(root.child("record"), dds_missing);
  app->live_ = read_live_config(root.child("live"), config_dir, dds_missing);
  if (opts.check_tool_blocks) opts.check_tool_blocks(app->record_, app->live_, app->dds_ != nullptr);

  // ---- rover description (camera calibration and mounts, wheels, the sun) and the devices ----
  ctx.set_rover(read_rover_description(root, config_dir));
  load_devices(root.child("devices"), ctx, opts, config_dir);
  check_rover_devices(root, ctx);

  // ---- rate groups (read first so membership errors point at the group), then components ----
  GroupPlan plan = read_rate_groups(root);
  app->configure_components(root.require_child("components"), plan);

  // ---- data flow: every consumed channel has one producer of its type, no cycle, order ----
  for (const auto& g : plan.configs) app->dataflow_.groups.push_back({g.name, g.members});
  app->dataflow_.ports = ctx.ports();
  app->dataflow_.check();
  ctx.link();
  app->build_rate_groups(plan);
  root.finish();
  return app;
}

void Application::start() {
  if (started_) return;
  health_ = &context_->channel<HealthSnapshot>("health/snapshot");
  if (dds_) {
    Clock* clk = &clock();
    rosout_ = std::make_shared<RosoutSink>(*dds_, name_, [clk] { return clk->now(); });
    spdlog::default_logger()->sinks().push_back(rosout_);
  }
  if (opts_.sim_time) {
    ros_time_offset().store(opts_.sim_ros_offset, std::memory_order_relaxed);
  } else {
    ros_time_offset().store(measure_realtime_offset(), std::memory_order_relaxed);
    ros_time_stop_ = false;
    ros_time_thread_ = std::thread([this] {
      std::unique_lock<std::mutex> lock(ros_time_mutex_);
      for (int tick = 1;
           !ros_time_cv_.wait_for(lock, std::chrono::milliseconds(250), [this] { return ros_time_stop_; }); ++tick) {
        if (tick % 4 == 0) ros_time_offset().store(measure_realtime_offset(), std::memory_order_relaxed);
        poll_events();
      }
    });
  }
  // Devices first (outside the rate groups), then components, then the schedule.
  for (hal::Device* d : context_->all_devices()) d->start();
  for (auto& c : components_) {
    c->activate();
    c->state_.store(Lifecycle::kActive);
  }
  if (dds_) {
    start_participant(*dds_, clock());
    tf_static_ = publish_static_transforms(*dds_, context_->rover(), clock().now());
    announce_node(*dds_, name_);
    if (!opts_.wait_for.empty()) wait_for_readers(*dds_, opts_.wait_for, opts_.wait_timeout);
    // Simulated time has no deadline to protect: deliver every sample before time moves on, so
    // a subscriber sees exactly what a real-time run would have published. /clock carries the
    // simulated time (ROS use_sim_time).
    if (opts_.sim_time) {
      dds::Participant* p = dds_.get();
      Clock* clk = &clock();
      executor_->set_after_cycle([this, p, clk, pub = clock_pub_] {
        pub(clk->now());
        poll_events();
        sync_participant(*p);
      });
    }
  }
  if (opts_.sim_time && !dds_) executor_->set_after_cycle([this] { poll_events(); });
  if (opts_.sim_time) {
    // Lockstep runs as fast as the CPU allows; a device that produces its output on a thread of
    // its own (the synthetic_drive camera renders) may not keep up. Time waits for it, as a ROS
    // node under use_sim_time waits for the simulator's /clock, for at most 10 s of wall time
    // per step (then it moves on and says so, once per device).
    std::vector<hal::Device*> devices = context_->all_devices();
    auto warned = std::make_shared<std::vector<bool>>(devices.size(), false);
    executor_->set_before_advance([devices, warned](TimeNs t) {
      const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(10);
      for (std::size_t i = 0; i < devices.size(); ++i) {
        while (!devices[i]->ready_for(t)) {
          if (std::chrono::steady_clock::now() > give_up) {
            if (!(*warned)[i])
              spdlog::warn(
                  "simulated time: device {} has not produced its output for t = {:.3f} s after 10 s of waiting; time "
                  "moves on without it",
                  devices[i]->id(), static_cast<double>(t) * 1e-9);
            (*warned)[i] = true;
            break;
          }
          std::this_thread::sleep_for(std::chrono::microseconds(200));
        }
      }
    });
  }
  executor_->start(view_.groups);
  started_ = true;
}

void Application::poll_events() {
  const auto lease = health_->acquire();
  if (!lease || lease->stamp == last_health_stamp_) return;
  last_health_stamp_ = lease->stamp;
  if (!health_events_) health_events_ = std::make_unique<HealthEvents>();
  for (const Event& e : health_events_->update(*lease)) {
    switch (e.severity) {
      case Event::Severity::kInfo: spdlog::info("{}", e.text); break;
      case Event::Severity::kWarn: spdlog::warn("{}", e.text); break;
      case Event::Severity::kError: spdlog::error("{}", e.text); break;
    }
  }
}

void Application::run(TimeNs duration, const std::atomic<bool>& stop_flag) {
  const TimeNs end = duration > 0 ? clock().now() + duration : INT64_MAX;
  executor_->run_until(end, stop_flag);
}

void Application::stop() {
  if (!started_) return;
  executor_->stop();
  for (auto& c : components_) {
    c->deactivate();
    c->state_.store(Lifecycle::kInactive);
  }
  const auto devices = context_->all_devices();
  for (auto it = devices.rbegin(); it != devices.rend(); ++it) (*it)->stop();
  if (ros_time_thread_.joinable()) {
    {
      std::lock_guard<std::mutex> lock(ros_time_mutex_);
      ros_time_stop_ = true;
    }
    ros_time_cv_.notify_all();
    ros_time_thread_.join();
  }
  if (rosout_) {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), rosout_), sinks.end());
  }
  if (dds_) stop_participant(*dds_);
  rosout_.reset();
  started_ = false;
}

}  // namespace regolith::runtime
