// Cross-process DDS test: a publisher in a child process (dds_test_publisher),
// `echo` here, over UDP on the loopback interface (CYCLONEDDS_URI =
// runtime/dds/cyclonedds_loopback.xml).
#include <cstdlib>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>

#include <gtest/gtest.h>

#include "dds_test_util.hpp"
#include "regolith/dds/topics.hpp"

extern char** environ;

namespace rd = regolith::dds;
namespace tst = regolith::dds::testing;
using regolith::kNsPerSec;

namespace {

class Child {
 public:
  explicit Child(std::vector<std::string> args) {
    std::vector<char*> argv;
    for (auto& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ok_ = posix_spawn(&pid_, argv[0], nullptr, nullptr, argv.data(), environ) == 0;
  }
  ~Child() {
    if (ok_ && !waited_) {
      kill(pid_, SIGTERM);
      wait();
    }
  }
  bool ok() const { return ok_; }
  int wait() {
    int status = 0;
    waitpid(pid_, &status, 0);
    waited_ = true;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = 0;
  bool ok_ = false;
  bool waited_ = false;
};

std::vector<nlohmann::json> lines_of(const std::string& s) {
  std::vector<nlohmann::json> out;
  std::istringstream is(s);
  std::string line;
  while (std::getline(is, line)) out.push_back(nlohmann::json::parse(line));
  return out;
}

}  // namespace

TEST(DdsProcess, EchoReceivesFromAnotherProcess) {
  tst::use_loopback_config();
  const auto domain = tst::test_domain();
  const std::string ns = tst::unique_ns();
  rd::Participant pp({domain, ns});
  // Subscribe to the latched map first (after the child has published it:
  // transient-local).
  Child child({REGOLITH_DDS_TEST_PUBLISHER, std::to_string(domain), ns, "300", "20"});
  ASSERT_TRUE(child.ok());

  std::ostringstream js_out;
  const std::size_t n = rd::echo(pp, "joint_states", {.count = 5, .timeout_ns = 20 * kNsPerSec}, js_out);
  ASSERT_EQ(n, 5u) << js_out.str();
  const auto js = lines_of(js_out.str());
  ASSERT_EQ(js.size(), 5u);
  for (std::size_t i = 0; i < js.size(); ++i) {
    EXPECT_EQ(js[i]["name"][1], "wheel_right");
    if (i > 0) {
      EXPECT_EQ(js[i]["header"]["stamp"]["sec"].get<int>(), js[i - 1]["header"]["stamp"]["sec"].get<int>() + 1);
    }
  }

  std::ostringstream diag_out;
  ASSERT_EQ(rd::echo(pp, "/diagnostics", {.count = 2, .timeout_ns = 20 * kNsPerSec}, diag_out), 2u);
  const auto diag = lines_of(diag_out.str());
  EXPECT_EQ(diag[0]["status"][0]["name"], "publisher: heartbeat");
  EXPECT_EQ(std::stoi(diag[1]["status"][0]["values"][0]["value"].get<std::string>()),
            std::stoi(diag[0]["status"][0]["values"][0]["value"].get<std::string>()) + 1);

  // The map was published once, seconds ago: a late transient-local reader
  // still gets it.
  std::ostringstream map_out;
  ASSERT_EQ(rd::echo(pp, "terrain/grid_map", {.count = 1, .timeout_ns = 20 * kNsPerSec}, map_out), 1u);
  const auto map = lines_of(map_out.str());
  EXPECT_EQ(map[0]["layers"][0], "elevation");
  EXPECT_EQ(map[0]["info"]["resolution"], 0.25);
  EXPECT_EQ(map[0]["data"][0]["data"][3], 1.5);
}

// ROS_AUTOMATIC_DISCOVERY_RANGE, as ROS 2 nodes read it: LOCALHOST still finds the publisher in
// another process on this machine (the discovery XML merged before CYCLONEDDS_URI is accepted and
// works); OFF hides it (a domain tag private to the process), so nothing reaches the reader.
// Each child inherits the environment it is spawned with.
namespace {
struct ScopedEnv {
  ScopedEnv(const char* name, const char* value) : name_(name) {
    if (const char* v = std::getenv(name)) saved_ = v, had_ = true;
    setenv(name, value, 1);
  }
  ~ScopedEnv() {
    if (had_)
      setenv(name_, saved_.c_str(), 1);
    else
      unsetenv(name_);
  }
  const char* name_;
  std::string saved_;
  bool had_ = false;
};
}  // namespace

TEST(DdsProcess, LocalhostDiscoveryFindsAnotherProcess) {
  tst::use_loopback_config();
  ScopedEnv range("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST");
  const auto domain = tst::test_domain();
  const std::string ns = tst::unique_ns();
  rd::Participant pp({domain, ns});
  EXPECT_EQ(pp.discovery().range, rd::DiscoveryRange::kLocalhost);
  Child child({REGOLITH_DDS_TEST_PUBLISHER, std::to_string(domain), ns, "300", "20"});
  ASSERT_TRUE(child.ok());
  std::ostringstream out;
  EXPECT_EQ(rd::echo(pp, "joint_states", {.count = 3, .timeout_ns = 20 * kNsPerSec}, out), 3u) << out.str();
}

TEST(DdsProcess, DiscoveryOffHidesTheProcess) {
  tst::use_loopback_config();
  const auto domain = tst::test_domain();
  const std::string ns = tst::unique_ns();
  std::unique_ptr<Child> child;
  {
    ScopedEnv range("ROS_AUTOMATIC_DISCOVERY_RANGE", "OFF");
    child = std::make_unique<Child>(
        std::vector<std::string>{REGOLITH_DDS_TEST_PUBLISHER, std::to_string(domain), ns, "100", "20"});
  }
  ASSERT_TRUE(child->ok());
  rd::Participant pp({domain, ns});
  // The publisher writes for 2 s; a reader that could discover it gets samples within the first
  // (the test above: 3 samples well inside its timeout).
  std::ostringstream out;
  EXPECT_EQ(rd::echo(pp, "joint_states", {.count = 1, .timeout_ns = 3 * kNsPerSec}, out), 0u) << out.str();
  // In one process, a second participant on the same domain with another range is refused.
  const rd::ParticipantConfig other{domain + 1, ns};
  const rd::DiscoveryOptions local{rd::DiscoveryRange::kLocalhost, {}}, off{rd::DiscoveryRange::kOff, {}};
  rd::Participant a(other, local);
  EXPECT_THROW(rd::Participant b(other, off), rd::DdsError);
  rd::Participant c(other, local);  // the same range joins
}
