// The Foxglove server end to end with an independent client (label integration, host only): this
// process publishes JointState samples over loopback DDS, a DdsRelay serves them in-process on a
// free port, and tests/live/js/client.js (Foxglove's @foxglove/ws-protocol client, schemas parsed
// by @foxglove/rosmsg, CDR decoded by @foxglove/rosmsg2-serialization) runs as a child process:
// serverInfo, every advertised channel (ros2msg / cdr) and the decoded names and positions.
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "cli_support.hpp"
#include "dds_test_util.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/live/dds_relay.hpp"
#include "regolith/runtime/application.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
namespace rt = regolith::testing;
namespace rd = regolith::dds;
namespace rl = regolith::live;
namespace m = regolith::msgs;
using nlohmann::json;

constexpr int kMessages = 5;

double joint_position(int i, int j) {
  return 0.01 * i + j;
}

}  // namespace

TEST(LiveNode, FoxgloveClientDecodesRelayedJointStates) {
  const fs::path js_dir = REGOLITH_LIVE_JS_DIR;
  if (!fs::exists(js_dir / "node_modules" / "@foxglove" / "ws-protocol")) {
    GTEST_SKIP() << "tests/live/js/node_modules missing: run `npm ci` there (deploy/setup.sh does)";
  }
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("live_" + ns);  // removed, whatever the test's outcome
  const fs::path& dir = tmp.path();
  const fs::path log = dir / "client.log";

  rd::Participant pub({domain, ns});
  auto js = pub.make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::find_topic("joint_states")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 16},
      [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 3}); });
  pub.start();

  rd::Participant sub({domain, ns});
  rl::FoxgloveServerOptions opt;
  opt.port = 0;
  rl::DdsRelay relay(sub, opt);
  relay.start();
  const std::string url = "ws://127.0.0.1:" + std::to_string(relay.server().port());
  const std::string topic = "/" + ns + "/joint_states";
  const pid_t pid =
      rt::spawn({REGOLITH_NODE, (js_dir / "client.js").string(), url, topic, std::to_string(kMessages)}, log);
  ASSERT_GT(pid, 0);

  // Publish a steady stream until the client has its messages (it subscribes after advertise).
  int status = 0;
  bool exited = false;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  for (int i = 0; std::chrono::steady_clock::now() < end; ++i) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    if (auto* s = js->begin()) {
      rd::set_time(s->header.stamp, (i + 1) * regolith::kNsPerMs);
      rd::copy_string(s->header.frame_id, 32, "base_link");
      rd::set_length(s->name, 3);
      rd::set_length(s->position, 3);
      rd::set_length(s->velocity, 3);
      for (int j = 0; j < 3; ++j) {
        rd::copy_string(s->name._buffer[j], 32, ("wheel_" + std::to_string(j)).c_str());
        s->position._buffer[j] = joint_position(i, j);
        s->velocity._buffer[j] = -joint_position(i, j);
      }
      js->commit();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (!exited) {
    kill(pid, SIGKILL);
    waitpid(pid, &status, 0);
  }
  relay.stop();
  pub.stop();
  const std::string out = rt::read_file(log);
  const std::string err = rt::read_file(log.string() + ".err");
  std::printf("%s", out.c_str());
  ASSERT_TRUE(exited && rt::exit_status(status) == 0) << out << err;

  std::istringstream lines(out);
  std::string line;
  int messages = 0;
  bool info = false, channels = false;
  while (std::getline(lines, line)) {
    const json j = json::parse(line);
    if (j.contains("serverInfo")) {
      info = true;
      EXPECT_EQ(j["serverInfo"]["name"], "regolith");
      EXPECT_EQ(j["serverInfo"]["supportedEncodings"], json::array({"cdr"}));
    } else if (j.contains("channels")) {
      channels = true;
      std::set<std::string> topics;
      for (const json& c : j["channels"]) {
        topics.insert(c["topic"].get<std::string>());
        EXPECT_EQ(c["encoding"], "cdr");
        EXPECT_EQ(c["schemaEncoding"], "ros2msg");
        if (c["topic"] == topic) {
          EXPECT_EQ(c["schemaName"], "sensor_msgs/msg/JointState");
        }
      }
      EXPECT_EQ(topics.size(), rd::known_topics().size());
      EXPECT_TRUE(topics.count(topic));
      EXPECT_TRUE(topics.count("/diagnostics"));
      EXPECT_TRUE(topics.count("/" + ns + "/terrain/grid_map"));
    } else if (j.contains("message")) {
      ++messages;
      const json& msg = j["message"];
      EXPECT_EQ(msg["header"]["frame_id"], "base_link");
      ASSERT_EQ(msg["name"], json::array({"wheel_0", "wheel_1", "wheel_2"}));
      ASSERT_EQ(msg["position"].size(), 3u);
      const double p0 = msg["position"][0].get<double>();
      const int i = static_cast<int>(std::lround(p0 / 0.01));
      const auto stamp_ns = static_cast<long long>(msg["header"]["stamp"]["sec"].get<double>()) * 1000000000LL +
                            msg["header"]["stamp"]["nanosec"].get<long long>();
      EXPECT_EQ(stamp_ns, (i + 1) * 1000000LL);
      for (int k = 0; k < 3; ++k) {
        EXPECT_DOUBLE_EQ(msg["position"][static_cast<std::size_t>(k)].get<double>(), joint_position(i, k));
        EXPECT_DOUBLE_EQ(msg["velocity"][static_cast<std::size_t>(k)].get<double>(), -joint_position(i, k));
      }
    }
  }
  EXPECT_TRUE(info);
  EXPECT_TRUE(channels);
  EXPECT_EQ(messages, kMessages);
  EXPECT_GE(relay.server().stats().messages_sent, static_cast<std::uint64_t>(kMessages));
  EXPECT_EQ(relay.server().stats().dropped_slow, 0u);
}

namespace {

/// `got` (the independent decoder's message) equals `want` (dds::to_json of a sample of the same
/// topic): every field, numbers by value; a CompressedImage's bytes (rendered by to_json as
/// {"bytes": N}) by count.
bool same(const json& got, const json& want) {
  if (want.is_object() && want.size() == 1 && want.contains("bytes") && got.is_array())
    return got.size() == want["bytes"].get<std::size_t>();
  if (want.is_object()) {
    if (!got.is_object() || got.size() != want.size()) return false;
    for (auto it = want.begin(); it != want.end(); ++it)
      if (!got.contains(it.key()) || !same(got[it.key()], it.value())) return false;
    return true;
  }
  if (want.is_array()) {
    if (!got.is_array() || got.size() != want.size()) return false;
    for (std::size_t i = 0; i < want.size(); ++i)
      if (!same(got[i], want[i])) return false;
    return true;
  }
  if (want.is_number() && got.is_string()) return got.get<std::string>() == want.dump();  // 64-bit ints
  return got == want;
}

}  // namespace

// Every channel of the mocked rover under simulated time, decoded by Foxglove's own client and
// ROS 2 CDR reader from the ros2msg schemas the server advertises, equals a sample of the same
// topic as `regolith echo` renders it (dds::to_json, taken by a second participant): the values
// are right and so is the ROS 2 wire layout of every message.
TEST(LiveNode, EveryChannelOfTheMockedRoverDecodesAsEchoPrintsIt) {
  const fs::path js_dir = REGOLITH_LIVE_JS_DIR;
  if (!fs::exists(js_dir / "node_modules" / "@foxglove" / "ws-protocol"))
    GTEST_SKIP() << "tests/live/js/node_modules missing: run `npm ci` there (deploy/setup.sh does)";
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("live_all_" + ns);  // removed, whatever the test's outcome
  const fs::path& dir = tmp.path();
  const fs::path log = dir / "client.log";

  regolith::cli::register_everything();
  std::string yaml = regolith::cli::embedded_mock_rover();  // on this test's own domain and namespace
  const auto swap = [&yaml](const std::string& from, const std::string& to) {
    const auto at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
  };
  swap("  domain: 0\n", "  domain: " + std::to_string(domain) + "\n");
  swap("  namespace: rover1", "  namespace: " + ns);
  auto app = regolith::runtime::Application::load(regolith::Params::load_string(yaml, "<embedded mock_rover>"),
                                                  {.sim_time = true, .enable_dds = true});

  // The reference: every sample of every topic rendered as `regolith echo` prints it.
  rd::Participant ref({domain, ns});
  std::vector<std::unique_ptr<rd::Subscription>> subs;
  for (const auto& t : rd::known_topics()) {
    rd::QosProfile q = t.reader_qos();
    q.keep_all = true;
    subs.push_back(std::make_unique<rd::Subscription>(ref, t.name, t.descriptor, q));
  }
  std::map<std::string, std::vector<json>> rendered;  // ROS name -> samples
  std::atomic<bool> stop_ref{false};
  std::thread taker([&] {
    while (!stop_ref.load()) {
      bool any = false;
      for (std::size_t k = 0; k < subs.size(); ++k) {
        const auto& t = rd::known_topics()[k];
        any |= subs[k]->take([&](const void* s, const dds_sample_info_t&) {
          rendered[ref.ros_name(t.name)].push_back(t.to_json(s));
        }) > 0;
      }
      if (!any) std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });

  rl::FoxgloveServerOptions opt;
  opt.port = 0;
  rl::DdsRelay relay(*app->dds(), opt);
  relay.start();
  const std::string url = "ws://127.0.0.1:" + std::to_string(relay.server().port());
  const pid_t pid = rt::spawn({REGOLITH_NODE, (js_dir / "client.js").string(), url, "*", "3"}, log);
  ASSERT_GT(pid, 0);
  // The client subscribes to every channel before the rover starts.
  const bool subscribed = rd::testing::eventually(
      [&] {
        for (std::uint32_t id = 1; id <= rd::known_topics().size(); ++id)
          if (!relay.server().has_subscribers(id)) return false;
        return true;
      },
      std::chrono::seconds(60));
  ASSERT_TRUE(subscribed) << rt::read_file(log) << rt::read_file(log.string() + ".err");

  std::atomic<bool> stop{false};
  app->start();
  app->run(6 * regolith::kNsPerSec, stop);
  app->stop();
  // Let the relay and the reference take what is still in flight, then close the server: the
  // client prints what it has and exits.
  const std::uint64_t before = relay.samples();
  rd::testing::eventually([&] { return relay.samples() > before; }, std::chrono::seconds(2));
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  relay.stop();
  const int client_status = rt::wait_exit(pid, std::chrono::seconds(60));
  stop_ref = true;
  taker.join();
  const std::string out = rt::read_file(log), err = rt::read_file(log.string() + ".err");
  ASSERT_EQ(client_status, 0) << err;

  std::map<std::string, int> decoded, matched;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    const json j = json::parse(line, nullptr, false);
    if (!j.is_object() || !j.contains("message")) continue;
    const std::string topic = j["topic"];
    ++decoded[topic];
    const auto it = rendered.find(topic);
    if (it == rendered.end()) continue;
    for (const json& want : it->second)
      if (same(j["message"], want)) {
        ++matched[topic];
        break;
      }
  }
  for (const auto& [topic, n] : decoded) {
    EXPECT_EQ(matched[topic], n) << topic << ": " << n << " decoded, " << matched[topic]
                                 << " equal to a sample echo rendered";
    std::printf("%-40s %d decoded, %d equal to echo\n", topic.c_str(), n, matched[topic]);
  }
  // What the mocked rover publishes in 6 s: every topic but /rosout (no event) and the latched ones
  // a late subscriber may have missed.
  for (const char* t : {"joint_states", "imu", "terrain/grid_map", "terrain/rocks", "terrain/wheel_sinkage",
                        "terrain/soil", "odom", "odom/wheel", "terrain/world_map", "terrain/world_rocks",
                        "preview/rocks/compressed", "preview/sinkage/compressed"})
    EXPECT_GT(decoded["/" + ns + "/" + t], 0) << t;
  EXPECT_GT(decoded["/diagnostics"], 0);
  EXPECT_GT(decoded["/tf"], 0);
  EXPECT_GT(decoded["/clock"], 0);
}
