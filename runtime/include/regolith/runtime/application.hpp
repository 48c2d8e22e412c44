#pragma once
// A deployment assembled from one YAML file: devices, components, rate groups, DDS. Loading
// validates everything (throwing ConfigError naming file:line:col and field) before any thread
// starts; `start` activates components, starts devices and the executor.
#include <atomic>
#include <condition_variable>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/context.hpp"
#include "regolith/runtime/dataflow.hpp"
#include "regolith/runtime/health.hpp"
#include "regolith/runtime/rate_group.hpp"

namespace regolith::dds {
class Participant;
}

namespace regolith::runtime {

class RosoutSink;     // event_log.hpp
class HealthEvents;   // event_log.hpp
struct RecordConfig;  // below
struct LiveConfig;    // below

struct AppOptions {
  bool sim_time = false;                 ///< run rate groups on the simulated clock, as fast as possible
  bool enable_dds = true;                ///< false: ignore the dds section (e.g. `config check`)
  bool open_devices = true;              ///< false: backends validate parameters without opening devices
  std::vector<std::string> wait_for{};   ///< DDS topics that need a subscriber before starting
  TimeNs wait_timeout = 30 * kNsPerSec;  ///< how long to wait for them
  /// Simulated time: the clock's value at start and the ROS time offset (ROS time = clock +
  /// offset; 0 = ROS's use_sim_time). `regolith replay` starts at a recording's own time origin and
  /// offset, so the replay's stamps are the recorded ones.
  TimeNs sim_start = kNsPerSec;
  TimeNs sim_ros_offset = 0;
  /// Applied to every device right after its backend built it (configure time, devices opened):
  /// a decorator such as the HAL recorder's (record::HalRecorder::wrap). Empty = none.
  std::function<std::unique_ptr<hal::Device>(std::unique_ptr<hal::Device>)> wrap_device{};
  /// Called once the `record:` and `live:` blocks are read, before the rover description, any
  /// device or component: the tool that owns those blocks checks what only it knows (topic names,
  /// the listen address, the token file) so a mistake there is reported before start-up renders
  /// or opens anything. `dds` is true when the deployment will have a DDS participant. Throw
  /// ConfigError located with the blocks' `where` fields. Empty = none.
  std::function<void(const RecordConfig&, const LiveConfig&, bool dds)> check_tool_blocks{};
};

/// The `record:` block (read here so `config check` lists it; the recording itself is done by the
/// tool, regolith::dds::DdsRecorder): record every DDS topic the deployment publishes into MCAP.
struct RecordConfig {
  std::string file;                  ///< MCAP file; empty = no recording (`run --record` overrides)
  std::vector<std::string> topics;   ///< topic names (`regolith echo --list`); empty = every known one
  std::string compression = "zstd";  ///< zstd | none
  bool hal = true;                   ///< also the devices' inputs (record::HalRecorder), for `regolith replay`
  double split_mb = 0.0;             ///< start a new file after about this many MiB (0 = never)
  double split_s = 0.0;              ///< ... or after this many seconds of recording (0 = never)
  std::string where_topics;          ///< file:line:col of record.topics (or of the block), for errors
  std::string where_file;            ///< file:line:col of record.file (or of the block), for errors
};

/// The `live:` block (read here so `config check` lists it; the server is started by the tool,
/// regolith::live::DdsRelay): a Foxglove WebSocket server of every DDS topic and the built-in page.
struct LiveConfig {
  bool enabled = false;                   ///< `regolith run --live ADDR` enables it too (and overrides listen)
  std::string listen = "127.0.0.1:8765";  ///< [ADDR:]PORT
  int max_clients = 8;                    ///< connections beyond this are refused
  double max_queue_mb = 8.0;              ///< per-client send queue limit; a client above it is dropped
  std::string token_file;   ///< access token file (mode 0600; relative to the config); required off loopback
  std::string where;        ///< file:line:col of live.listen (or of the block), for errors
  std::string token_where;  ///< file:line:col of live.token_file
};

/// Everything the health monitor and the live summary read.
struct SystemView {
  std::vector<RateGroup*> groups;
  std::vector<Component*> components;
  Context* context = nullptr;
};

class Application {
 public:
  /// Build and configure from a parsed file. Throws ConfigError.
  static std::unique_ptr<Application> load(Params root, const AppOptions& opts);
  ~Application();

  void start();
  /// Run until `duration` (ns of executor time; <= 0 = until `stop_flag`) or `stop_flag`.
  void run(TimeNs duration, const std::atomic<bool>& stop_flag);
  void stop();

  Context& context() { return *context_; }
  Clock& clock();
  const SystemView& view() const { return view_; }
  const std::vector<ResolvedParam>& resolved() const { return *resolved_; }
  /// The checked data-flow graph (components, rate groups, devices, channels).
  const DataFlowGraph& dataflow() const { return dataflow_; }
  dds::Participant* dds() { return dds_.get(); }
  bool sim_time() const { return opts_.sim_time; }
  const std::string& name() const { return name_; }
  const RecordConfig& record_config() const { return record_; }
  const LiveConfig& live_config() const { return live_; }

 private:
  Application() = default;
  // load()'s stages. The rate groups are read before the components (membership errors point at
  // the group) and built after them and the data-flow check.
  struct GroupPlan {
    std::vector<RateGroupConfig> configs;
    std::vector<Params> params;                    ///< each group's block, for errors found later
    std::map<std::string, std::string> member_of;  ///< component -> its rate group
  };
  static GroupPlan read_rate_groups(Params& root);
  void configure_components(Params comps, const GroupPlan& plan);
  void build_rate_groups(GroupPlan& plan);
  AppOptions opts_;
  std::string name_;
  RecordConfig record_;
  LiveConfig live_;
  std::unique_ptr<SimClock> sim_clock_;
  std::unique_ptr<Executor> executor_;
  std::shared_ptr<dds::Participant> dds_;
  std::shared_ptr<void> tf_static_;        // the /tf_static writer (latched for late subscribers)
  std::function<void(TimeNs)> clock_pub_;  // /clock under --sim-time
  // The event log: health snapshots -> events (spdlog), and spdlog -> /rosout when on DDS.
  std::shared_ptr<RosoutSink> rosout_;
  std::unique_ptr<HealthEvents> health_events_;
  LatestPool<HealthSnapshot>* health_ = nullptr;
  TimeNs last_health_stamp_ = -1;
  void poll_events();
  std::unique_ptr<Context> context_;
  std::vector<std::unique_ptr<Component>> components_;
  std::vector<std::unique_ptr<RateGroup>> groups_;
  SystemView view_;
  DataFlowGraph dataflow_;
  std::shared_ptr<std::vector<ResolvedParam>> resolved_;
  bool started_ = false;
  // A non-real-time housekeeping thread while running on the system clock: it re-measures ROS
  // time (realtime - monotonic, regolith::ros_time_offset) every second and turns new health
  // snapshots into events every 250 ms. Under --sim-time the offset is 0 and events are polled
  // after each simulated cycle.
  std::thread ros_time_thread_;
  std::mutex ros_time_mutex_;
  std::condition_variable ros_time_cv_;
  bool ros_time_stop_ = false;
};

/// Registers everything built into the runtime (health, joint_state_publisher components).
void register_builtin_components();

}  // namespace regolith::runtime
