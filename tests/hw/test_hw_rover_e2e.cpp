// Driver test (label hw): the SMART rover deployment (config/smart_rover.yaml) switched to real
// drivers runs end to end. At test time the shipped file is rewritten to use vivid for the V4L2
// wheel camera (selected by bus_info) and vcan0 for the SocketCAN wheel encoders, with a DDS domain
// and namespace of its own; `regolith run` runs it in one process, `regolith echo joint_states` and
// `regolith echo /diagnostics` subscribe from two others, and this process writes encoder frames
// on vcan0 with a raw CAN socket. Checked: joint_states carry exactly the encoder counts sent
// (times the configured scale), per wheel in send order, with increasing stamps; diagnostics report
// the camera streaming with frames increasing and no fault.
//
// Adaptations to the VM (each asserted against the shipped file so a change there is noticed):
//  * the libcamera `front` camera and its consumers `sfs` / `traversability` / `terrain_map` are removed (vimc
//    start-up under TCG costs 5-10 s per process; libcamera is covered by test_hw_libcamera);
//  * the `rear` V4L2 camera and its consumer `soil` are removed: vivid offers one capture node
//    and the wheel camera holds it.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "child_process.hpp"
#include "hw_util.hpp"
#include "json_lines.hpp"
#include "regolith/hal_v4l2/v4l2.hpp"
#include "temp_dir.hpp"
#include "test_domain.hpp"

namespace fs = std::filesystem;
namespace rt = regolith::testing;
using namespace regolith;

namespace {

constexpr const char* kCan = "vcan0";
constexpr int kWheels = 6;
constexpr std::uint32_t kFirstId = 0x101;  // wheel_fl .. wheel_rr = 0x101 .. 0x106 in the shipped file
constexpr double kScale = 1.5339808e-3;    // rad/count in the shipped file
/// Count sent for wheel `w` in round `r`: distinct per wheel, increasing per round, signed values too.
std::int32_t count_for(int w, int r) {
  return (w % 2 == 0 ? 1 : -1) * (1000 * (w + 1) + r);
}

/// Drops `name` from a YAML map, failing the test when it is not there.
void remove_key(YAML::Node map, const std::string& name, const std::string& where) {
  ASSERT_TRUE(map[name].IsDefined()) << where << "." << name << " no longer in config/smart_rover.yaml";
  map.remove(name);
}

/// Writes one frame per wheel every 20 ms on a raw CAN socket until stopped.
class EncoderFeeder {
 public:
  explicit EncoderFeeder(int fd) : fd_(fd) {
    thread_ = std::thread([this] {
      while (!stop_.load()) {
        const int r = rounds_.load();
        for (int w = 0; w < kWheels; ++w) {
          can_frame f{};
          f.can_id = kFirstId + static_cast<std::uint32_t>(w);
          f.len = 4;
          const std::int32_t c = count_for(w, r);
          std::memcpy(f.data, &c, 4);  // little endian (x86 guest), as configured
          if (write(fd_, &f, sizeof f) != static_cast<ssize_t>(sizeof f)) ++write_errors_;
        }
        rounds_.store(r + 1);
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
      }
    });
  }
  ~EncoderFeeder() { stop(); }
  void stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  int rounds() const { return rounds_.load(); }
  int write_errors() const { return write_errors_.load(); }

 private:
  int fd_;
  std::atomic<bool> stop_{false};
  std::atomic<int> rounds_{0}, write_errors_{0};
  std::thread thread_;
};

const nlohmann::json* find_status(const nlohmann::json& diag, const std::string& name) {
  for (const auto& st : diag["status"])
    if (st["name"] == name) return &st;
  return nullptr;
}

long long value_of(const nlohmann::json& st, const std::string& key) {
  for (const auto& kv : st["values"])
    if (kv["key"] == key) return std::stoll(kv["value"].get<std::string>());
  ADD_FAILURE() << "diagnostic value '" << key << "' missing in " << st.dump();
  return -1;
}

}  // namespace

TEST(HwRoverEndToEnd, SmartRoverOnVividAndVcanPublishesJointStatesAndDiagnostics) {
  const auto devices = hal::v4l2::list_v4l2_devices(false);
  const hal::v4l2::DeviceInfo* vivid = nullptr;
  for (const auto& d : devices)
    if (d.driver == "vivid" && d.capture) {
      vivid = &d;
      break;
    }
  if (vivid == nullptr) GTEST_SKIP() << "no vivid capture node (load vivid, or run tests/hw/run.sh BUILD_DIR)";
  if (if_nametoindex(kCan) == 0) GTEST_SKIP() << "no vcan0 (needs the vcan driver: run tests/hw/run.sh BUILD_DIR)";

  // kept when the test fails: the deployment, the run's log and its CSV summaries
  const regolith::testing::TempDir tmp("hw_e2e", regolith::testing::TempDir::kKeepOnFailure);
  const fs::path& dir = tmp.path();
  const std::string ns = "hwe2e" + std::to_string(getpid());
  const int domain = static_cast<int>(regolith::testing::test_domain());
  setenv("CYCLONEDDS_URI", ("file://" + std::string(REGOLITH_HW_DATA_DIR) + "/cyclonedds_loopback.xml").c_str(), 0);

  // ---- the deployment, derived from the shipped SMART rover file
  YAML::Node cfg = YAML::LoadFile(std::string(REGOLITH_HW_DATA_DIR) + "/smart_rover.yaml");
  cfg["dds"]["namespace"] = ns;
  cfg["dds"]["domain"] = domain;
  YAML::Node cams = cfg["devices"]["cameras"];
  ASSERT_EQ(cams["front"]["backend"].as<std::string>(), "libcamera");
  ASSERT_EQ(cams["rear"]["backend"].as<std::string>(), "v4l2");
  YAML::Node wheel_cam = cams["wheel_cam"];
  ASSERT_EQ(wheel_cam["backend"].as<std::string>(), "v4l2");
  wheel_cam.remove("device");
  wheel_cam["bus_info"] = vivid->bus_info;
  remove_key(cams, "front", "devices.cameras");
  remove_key(cams, "rear", "devices.cameras");
  remove_key(cfg["rover"]["cameras"], "front", "rover.cameras");  // their calibrations go with them
  remove_key(cfg["rover"]["cameras"], "rear", "rover.cameras");
  YAML::Node wheels = cfg["devices"]["encoders"]["wheels"];
  ASSERT_EQ(wheels["backend"].as<std::string>(), "socketcan");
  wheels["interface"] = kCan;
  ASSERT_EQ(wheels["wheels"].size(), static_cast<std::size_t>(kWheels));
  int w = 0;
  for (const auto& kv : wheels["wheels"]) {  // the feeder's ids and scale are the shipped ones
    ASSERT_EQ(kv.second["id"].as<std::uint32_t>(), kFirstId + static_cast<std::uint32_t>(w)) << kv.first;
    ASSERT_DOUBLE_EQ(kv.second["scale"].as<double>(), kScale) << kv.first;
    ASSERT_EQ(kv.second["length"].as<int>(), 4);
    ++w;
  }
  const std::set<std::string> dropped = {"sfs", "traversability", "terrain_map", "soil"};
  for (const auto& c : dropped) remove_key(cfg["components"], c, "components");
  YAML::Node groups(YAML::NodeType::Sequence);
  for (const auto& g : cfg["rate_groups"]) {
    YAML::Node members(YAML::NodeType::Sequence);
    for (const auto& m : g["members"])
      if (!dropped.count(m.as<std::string>())) members.push_back(m.as<std::string>());
    if (members.size() == 0) continue;
    YAML::Node copy = YAML::Clone(g);
    copy["members"] = members;
    groups.push_back(copy);
  }
  cfg["rate_groups"] = groups;
  const fs::path cfg_file = dir / "smart_rover_hw.yaml";
  std::ofstream(cfg_file) << YAML::Dump(cfg);

  // ---- encoder frames on vcan0
  const int can_fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
  ASSERT_GE(can_fd, 0) << "CAN_RAW socket: " << std::strerror(errno);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(if_nametoindex(kCan));
  ASSERT_EQ(bind(can_fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0) << std::strerror(errno);

  // ---- subscribers, then the rover (which waits for them)
  const std::string exe = REGOLITH_EXE;
  const std::string js_out = (dir / "joint_states.jsonl").string();
  const std::string diag_out = (dir / "diagnostics.jsonl").string();
  const std::string run_out = (dir / "run.txt").string();
  constexpr int kJointSamples = 40;  // ~50 fresh samples/s are sent for 6 s
  constexpr int kDiagSamples = 8;    // health runs at 2 Hz for 6 s
  const pid_t js = rt::spawn({exe, "echo", "joint_states", "--count", std::to_string(kJointSamples), "--timeout", "45",
                              "--namespace", ns, "--domain", std::to_string(domain)},
                             js_out);
  const pid_t diag = rt::spawn({exe, "echo", "/diagnostics", "--count", std::to_string(kDiagSamples), "--timeout", "45",
                                "--namespace", ns, "--domain", std::to_string(domain)},
                               diag_out);
  ASSERT_GT(js, 0);
  ASSERT_GT(diag, 0);
  EncoderFeeder feeder(can_fd);
  const pid_t rover = rt::spawn({exe, "run", "--config", cfg_file.string(), "--duration", "6", "--quiet", "--wait-for",
                                 "joint_states", "--wait-for", "/diagnostics", "--wait-timeout", "30"},
                                run_out);
  ASSERT_GT(rover, 0);
  const int rover_rc = rt::wait_exit(rover, std::chrono::seconds(50));
  const int js_rc = rt::wait_exit(js, std::chrono::seconds(10));
  const int diag_rc = rt::wait_exit(diag, std::chrono::seconds(10));
  feeder.stop();
  close(can_fd);
  EXPECT_EQ(rover_rc, 0) << "regolith run: " << rt::read_file(run_out + ".err");
  EXPECT_EQ(js_rc, 0) << "echo joint_states: " << rt::read_file(js_out + ".err");
  EXPECT_EQ(diag_rc, 0) << "echo /diagnostics: " << rt::read_file(diag_out + ".err");
  EXPECT_EQ(feeder.write_errors(), 0);
  const int rounds = feeder.rounds();
  ASSERT_GT(rounds, 0);

  // ---- joint_states: the counts sent, in order, with increasing stamps
  const auto joints = rt::read_json_lines(js_out);
  ASSERT_EQ(static_cast<int>(joints.size()), kJointSamples);
  ASSERT_EQ(joints.front()["name"].size(), static_cast<std::size_t>(kWheels));
  EXPECT_EQ(joints.front()["name"][0], "wheel_fl");
  EXPECT_EQ(joints.front()["name"][5], "wheel_rr");
  std::vector<int> last_round(kWheels, -1);
  std::set<int> rounds_seen;
  for (std::size_t i = 0; i < joints.size(); ++i) {
    if (i > 0) {
      EXPECT_GT(rt::header_stamp_ns(joints[i]), rt::header_stamp_ns(joints[i - 1])) << "joint_states sample " << i;
    }
    ASSERT_EQ(joints[i]["position"].size(), static_cast<std::size_t>(kWheels));
    for (int k = 0; k < kWheels; ++k) {
      const double pos = joints[i]["position"][static_cast<std::size_t>(k)].get<double>();
      if (pos == 0.0 && last_round[static_cast<std::size_t>(k)] < 0) continue;  // wheel not heard yet
      const double counts = pos / kScale;
      const long long c = std::llround(counts);
      ASSERT_NEAR(counts, static_cast<double>(c), 1e-6) << "wheel " << k << " sample " << i << ": not a whole count";
      const long long sign = k % 2 == 0 ? 1 : -1;
      const long long r = sign * c - 1000LL * (k + 1);  // the round whose count this is
      ASSERT_GE(r, 0) << "wheel " << k << " sample " << i << ": count " << c << " was never sent";
      ASSERT_LT(r, rounds) << "wheel " << k << " sample " << i << ": count " << c << " was never sent";
      EXPECT_GE(r, last_round[static_cast<std::size_t>(k)]) << "wheel " << k << " went backwards at sample " << i;
      last_round[static_cast<std::size_t>(k)] = static_cast<int>(r);
      if (k == 0) rounds_seen.insert(static_cast<int>(r));
    }
  }
  for (int k = 0; k < kWheels; ++k)
    EXPECT_GE(last_round[static_cast<std::size_t>(k)], 0) << "wheel " << k << " never published";
  EXPECT_GE(rounds_seen.size(), static_cast<std::size_t>(kJointSamples / 2))
      << "encoder values did not follow the frames sent";

  // ---- diagnostics: the camera and the encoders streaming, no faults
  const auto diags = rt::read_json_lines(diag_out);
  ASSERT_EQ(static_cast<int>(diags.size()), kDiagSamples);
  for (std::size_t i = 1; i < diags.size(); ++i)
    EXPECT_GT(rt::header_stamp_ns(diags[i]), rt::header_stamp_ns(diags[i - 1]));
  long long first_frames = -1;
  for (const auto& d : diags) {
    const nlohmann::json* cam = find_status(d, "camera: wheel_cam");
    ASSERT_NE(cam, nullptr) << "no camera: wheel_cam in " << d.dump();
    if (cam->at("message") == "streaming" && first_frames < 0) first_frames = value_of(*cam, "frames");
  }
  const nlohmann::json& last = diags.back();
  const nlohmann::json* cam = find_status(last, "camera: wheel_cam");
  EXPECT_EQ(cam->at("message"), "streaming");
  EXPECT_EQ(cam->at("level"), 0);
  EXPECT_EQ(value_of(*cam, "faults"), 0);
  ASSERT_GE(first_frames, 0) << "the camera never reported streaming";
  EXPECT_GT(value_of(*cam, "frames"), first_frames) << "camera frames did not increase between reports";
  const nlohmann::json* enc = find_status(last, "encoders: wheels");
  ASSERT_NE(enc, nullptr);
  EXPECT_EQ(enc->at("message"), "streaming");
  EXPECT_EQ(value_of(*enc, "faults"), 0);
  EXPECT_GE(value_of(*enc, "samples"), static_cast<long long>(kWheels * kJointSamples));
  // A component is ok, or (a timing, not a fault: a starved VM slips its 100 Hz group) named as
  // the culprit of its group's slips; never in error, never with stale inputs.
  const auto ok_or_overrun = [](const nlohmann::json& c) {
    return c.at("level") == 0 || (c.at("level") == 1 && c.at("message") == "overruns its rate group's period");
  };
  const nlohmann::json* js_comp = find_status(last, "component: joint_states");
  ASSERT_NE(js_comp, nullptr);
  EXPECT_TRUE(ok_or_overrun(*js_comp)) << js_comp->dump();
  EXPECT_EQ(value_of(*js_comp, "errors"), 0) << js_comp->dump();
  EXPECT_EQ(value_of(*js_comp, "stale_inputs"), 0) << js_comp->dump();
  EXPECT_NE(find_status(last, "component: wheel_sinkage"), nullptr) << "wheel_sinkage (vivid consumer) missing";
  // the shipped wheel camera preview runs on the real V4L2 path too
  const auto* preview = find_status(last, "component: wheel_preview");
  ASSERT_NE(preview, nullptr) << "wheel_preview missing";
  EXPECT_TRUE(ok_or_overrun(*preview)) << preview->dump();
  EXPECT_EQ(value_of(*preview, "errors"), 0) << preview->dump();
}
