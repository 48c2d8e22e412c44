// The Foxglove server end to end with an independent client (label integration, host only): this
// process publishes JointState samples over loopback DDS, a DdsRelay serves them in-process on a
// free port, and tests/live/js/client.js (Foxglove's @foxglove/ws-protocol client, schemas parsed
// by @foxglove/rosmsg, CDR decoded by @foxglove/rosmsg2-serialization) runs as a child process:
// serverInfo, every advertised channel (ros2msg / cdr) and the decoded names and positions.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "dds_test_util.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/live/dds_relay.hpp"

extern char** environ;

namespace {

namespace fs = std::filesystem;
namespace rd = regolith::dds;
namespace rl = regolith::live;
namespace m = regolith::msgs;
using nlohmann::json;

constexpr int kMessages = 5;

pid_t spawn(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, 2, (log.string() + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

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
  const fs::path dir = fs::temp_directory_path() / ("regolith_live_" + ns);
  fs::create_directories(dir);
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
  const pid_t pid = spawn({REGOLITH_NODE, (js_dir / "client.js").string(), url, topic, std::to_string(kMessages)}, log);
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
  const std::string out = slurp(log);
  const std::string err = slurp(log.string() + ".err");
  std::printf("%s", out.c_str());
  ASSERT_TRUE(exited && WIFEXITED(status) && WEXITSTATUS(status) == 0) << out << err;

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
