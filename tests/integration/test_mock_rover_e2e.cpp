// End to end: `regolith run --config config/mock_rover.yaml --sim-time --duration 10` in one
#include "child_process.hpp"
#include "json_lines.hpp"
#include "temp_dir.hpp"
#include "test_domain.hpp"
// process, `regolith echo` subscribers in two others; every JointState and DiagnosticArray sample
// arrives, with increasing stamps. The deployment gets a namespace and domain of its own so
// parallel runs cannot cross-talk.
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

namespace fs = std::filesystem;
namespace rt = regolith::testing;

namespace {}  // namespace

TEST(MockRoverEndToEnd, SubscribersInOtherProcessesReceiveEverySample) {
  const regolith::testing::TempDir tmp("e2e");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const std::string ns = "e2e" + std::to_string(getpid());
  const std::string domain = std::to_string(regolith::testing::test_domain());
  setenv("CYCLONEDDS_URI",
         ("file://" + std::string(REGOLITH_SOURCE_DIR) + "/runtime/dds/cyclonedds_loopback.xml").c_str(), 0);

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
  const pid_t js = rt::spawn({exe, "echo", "joint_states", "--count", std::to_string(expect_js), "--timeout", "60",
                              "--namespace", ns, "--domain", domain},
                             js_out);
  const pid_t diag = rt::spawn({exe, "echo", "/diagnostics", "--count", std::to_string(expect_diag), "--timeout", "60",
                                "--namespace", ns, "--domain", domain},
                               diag_out);
  ASSERT_GT(js, 0);
  ASSERT_GT(diag, 0);
  const pid_t rover = rt::spawn({exe, "run", "--config", cfg_file.string(), "--sim-time", "--duration", "10",
                                 "--wait-for", "joint_states", "--wait-for", "/diagnostics", "--quiet"},
                                (dir / "run.txt").string());
  ASSERT_GT(rover, 0);
  EXPECT_EQ(rt::wait_exit(rover), 0) << rt::read_file((dir / "run.txt.err").string());
  EXPECT_EQ(rt::wait_exit(js), 0) << rt::read_file(js_out + ".err");
  EXPECT_EQ(rt::wait_exit(diag), 0) << rt::read_file(diag_out + ".err");

  const auto joints = rt::read_json_lines(js_out);
  ASSERT_EQ(static_cast<int>(joints.size()), expect_js);
  EXPECT_EQ(joints.front()["name"].size(), 6u);
  for (std::size_t i = 1; i < joints.size(); ++i) {
    EXPECT_GT(rt::header_stamp_ns(joints[i]), rt::header_stamp_ns(joints[i - 1])) << "sample " << i;
    EXPECT_GE(joints[i]["position"][0].get<double>(), joints[i - 1]["position"][0].get<double>());
  }
  const auto diags = rt::read_json_lines(diag_out);
  ASSERT_EQ(static_cast<int>(diags.size()), expect_diag);
  for (std::size_t i = 1; i < diags.size(); ++i)
    EXPECT_GT(rt::header_stamp_ns(diags[i]), rt::header_stamp_ns(diags[i - 1]));
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
