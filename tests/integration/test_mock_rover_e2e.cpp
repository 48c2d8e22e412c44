// End to end: `regolith run --config config/mock_rover.yaml --sim-time --duration 10` in one
#include "temp_dir.hpp"
#include "test_domain.hpp"
// process, `regolith echo` subscribers in two others; every JointState and DiagnosticArray sample
// arrives, with increasing stamps. The deployment gets a namespace and domain of its own so
// parallel runs cannot cross-talk.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>
#include <yaml-cpp/yaml.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

extern char** environ;
namespace fs = std::filesystem;

namespace {

pid_t spawn(const std::vector<std::string>& args, const std::string& out_file) {
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, (out_file + ".err").c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

int wait_exit(pid_t pid) {
  int status = 0;
  if (waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

std::vector<nlohmann::json> read_json_lines(const std::string& file) {
  std::vector<nlohmann::json> out;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty()) out.push_back(nlohmann::json::parse(line));
  }
  return out;
}

std::string slurp(const std::string& f) {
  std::ifstream in(f);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

long long stamp_ns(const nlohmann::json& m) {
  return m["header"]["stamp"]["sec"].get<long long>() * 1000000000LL + m["header"]["stamp"]["nanosec"].get<long long>();
}

}  // namespace

TEST(MockRoverEndToEnd, SubscribersInOtherProcessesReceiveEverySample) {
  const regolith::testing::TempDir tmp("e2e");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const std::string ns = "e2e" + std::to_string(getpid());
  const std::string domain = std::to_string(regolith::testing::test_domain());
  setenv("CYCLONEDDS_URI", ("file://" + std::string(REGOLITH_SOURCE_DIR) + "/runtime/dds/cyclonedds_loopback.xml").c_str(), 0);

  // The shipped mock rover, with its own namespace and domain.
  YAML::Node cfg = YAML::LoadFile(std::string(REGOLITH_SOURCE_DIR) + "/config/mock_rover.yaml");
  cfg["dds"]["namespace"] = ns;
  cfg["dds"]["domain"] = std::stoi(domain);
  const fs::path cfg_file = dir / "mock_rover.yaml";
  std::ofstream(cfg_file) << YAML::Dump(cfg);

  // Expected counts from the configuration: 10 s of simulated time, releases at both ends.
  double js_rate = 0, health_rate = 0;
  for (const auto& g : cfg["rate_groups"]) {
    for (const auto& m : g["members"]) {
      const double hz = g["rate_hz"] ? g["rate_hz"].as<double>() : 1000.0 / g["period_ms"].as<double>();
      if (m.as<std::string>() == "joint_states") js_rate = hz;
      if (m.as<std::string>() == "health") health_rate = hz;
    }
  }
  ASSERT_GT(js_rate, 0);
  ASSERT_GT(health_rate, 0);
  const int expect_js = static_cast<int>(js_rate * 10) + 1;
  const int expect_diag = static_cast<int>(health_rate * 10) + 1;

  const std::string exe = REGOLITH_EXE;
  const std::string js_out = (dir / "joint_states.jsonl").string();
  const std::string diag_out = (dir / "diagnostics.jsonl").string();
  const pid_t js = spawn({exe, "echo", "joint_states", "--count", std::to_string(expect_js), "--timeout", "60",
                          "--namespace", ns, "--domain", domain}, js_out);
  const pid_t diag = spawn({exe, "echo", "/diagnostics", "--count", std::to_string(expect_diag), "--timeout", "60",
                            "--namespace", ns, "--domain", domain}, diag_out);
  ASSERT_GT(js, 0);
  ASSERT_GT(diag, 0);
  const pid_t rover = spawn({exe, "run", "--config", cfg_file.string(), "--sim-time", "--duration", "10",
                             "--wait-for", "joint_states", "--wait-for", "/diagnostics", "--quiet"}, (dir / "run.txt").string());
  ASSERT_GT(rover, 0);
  EXPECT_EQ(wait_exit(rover), 0) << slurp((dir / "run.txt.err").string());
  EXPECT_EQ(wait_exit(js), 0) << slurp(js_out + ".err");
  EXPECT_EQ(wait_exit(diag), 0) << slurp(diag_out + ".err");

  const auto joints = read_json_lines(js_out);
  ASSERT_EQ(static_cast<int>(joints.size()), expect_js);
  EXPECT_EQ(joints.front()["name"].size(), 6u);
  for (std::size_t i = 1; i < joints.size(); ++i) {
    EXPECT_GT(stamp_ns(joints[i]), stamp_ns(joints[i - 1])) << "sample " << i;
    EXPECT_GE(joints[i]["position"][0].get<double>(), joints[i - 1]["position"][0].get<double>());
  }
  const auto diags = read_json_lines(diag_out);
  ASSERT_EQ(static_cast<int>(diags.size()), expect_diag);
  for (std::size_t i = 1; i < diags.size(); ++i) EXPECT_GT(stamp_ns(diags[i]), stamp_ns(diags[i - 1]));
  // The last report names every component, each healthy.
  bool saw_joint_component = false;
  for (const auto& st : diags.back()["status"]) {
    if (st["name"] == "component: joint_states") {
      saw_joint_component = true;
      EXPECT_EQ(st["level"], 0);
    }
  }
  EXPECT_TRUE(saw_joint_component);
}
