// Declared data flow: components declare the channels they produce and consume (name + payload
// type) while configuring; the loader checks the graph before anything runs. One test per class
// of violation (each a located ConfigError), a linked deployment that runs, and the printed graph
// (`regolith config check --dot` parsed by Graphviz's dot).
#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>

#include <gtest/gtest.h>

#include "regolith/core/error.hpp"
#include "regolith/runtime/application.hpp"
#include "temp_dir.hpp"

using namespace regolith;
using namespace regolith::runtime;

// Payloads at global scope: their printed type names are "Meters" and "Counts".
struct Meters {
  double value = 0.0;
};
struct Counts {
  long value = 0;
};

namespace {

// A test node: `produces` / `consumes` channel names with payload `meters` or `counts`. Each
// step writes 1 + the sum of what it read, so a linked chain counts its depth.
class Node final : public Component {
 public:
  void configure(Params& p, Context& ctx) override {
    const auto payload = p.get<std::string>("payload", "meters", {.choices = {"meters", "counts"}});
    for (const auto& name : p.get<std::vector<std::string>>("consumes", {})) {
      if (payload == "meters")
        in_.push_back(&ctx.consume<Meters>(name));
      else
        ctx.consume<Counts>(name);
    }
    for (const auto& name : p.get<std::vector<std::string>>("produces", {})) {
      if (payload == "meters")
        out_.push_back(&ctx.produce<Meters>(name));
      else
        ctx.produce<Counts>(name);
    }
  }
  void step(const CycleInfo&) override {
    double sum = 1.0;
    for (const auto* in : in_)
      if (auto l = in->acquire()) sum += l->value;
    for (auto* out : out_) {
      if (Meters* m = out->begin_write()) {
        m->value = sum;
        out->commit();
      }
    }
  }

 private:
  std::vector<const Input<Meters>*> in_;
  std::vector<LatestPool<Meters>*> out_;
};

void register_nodes() {
  static bool done = false;
  if (done) return;
  done = true;
  ComponentRegistry::instance().add("node", "test data-flow node", [] { return std::make_unique<Node>(); });
}

std::string deployment(const std::string& members, const std::string& components) {
  return "name: flow\ndds: {enabled: false}\nrate_groups:\n  - {name: g, rate_hz: 10, members: [" + members +
         "]}\ncomponents:\n" + components;
}

std::string load_error(const std::string& yaml) {
  register_nodes();
  try {
    Application::load(Params::load_string(yaml, "flow.yaml"), {.sim_time = true, .enable_dds = false});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(DataFlow, ConsumerWithoutProducerIsALocatedError) {
  const std::string e = load_error(deployment("a, b", R"(  a: {type: node, produces: [depth]}
  b: {type: node, consumes: [dtm]}
)"));
  EXPECT_EQ(e,
            "flow.yaml:7:6: components.b: consumes channel 'dtm' (Meters), which no component of this deployment "
            "produces (produced here: 'depth')");
}

TEST(DataFlow, TwoProducersAreALocatedError) {
  const std::string e = load_error(deployment("a, b, c", R"(  a: {type: node, produces: [dtm]}
  b: {type: node, produces: [dtm]}
  c: {type: node, consumes: [dtm]}
)"));
  EXPECT_EQ(e,
            "flow.yaml:7:6: components.b: produces channel 'dtm', which 'a' already produces: a channel has "
            "exactly one producer");
}

TEST(DataFlow, PayloadTypeMismatchIsALocatedError) {
  const std::string e = load_error(deployment("a, b", R"(  a: {type: node, produces: [dtm]}
  b: {type: node, consumes: [dtm], payload: counts}
)"));
  EXPECT_EQ(e, "flow.yaml:7:6: components.b: consumes channel 'dtm' as Counts but 'a' produces Meters");
}

TEST(DataFlow, CycleIsALocatedError) {
  const std::string e = load_error(deployment("a, b, c", R"(  a: {type: node, produces: [x], consumes: [z]}
  b: {type: node, produces: [y], consumes: [x]}
  c: {type: node, produces: [z], consumes: [y]}
)"));
  EXPECT_EQ(e,
            "flow.yaml:6:6: components.a: data-flow cycle a -> b -> c -> a: each component would read what it "
            "wrote a cycle earlier; break the loop");
}

TEST(DataFlow, ConsumerAheadOfItsProducerInOneRateGroupIsALocatedError) {
  const std::string e = load_error(deployment("b, a", R"(  a: {type: node, produces: [dtm]}
  b: {type: node, consumes: [dtm]}
)"));
  EXPECT_EQ(e,
            "flow.yaml:7:6: components.b: runs before 'a', the producer of 'dtm', in rate group 'g': it would "
            "read the previous cycle's value; list 'a' first in members");
}

TEST(DataFlow, LinkedChainRunsInOrderAndIsPrinted) {
  register_nodes();
  auto app = Application::load(Params::load_string(deployment("a, b, c", R"(  a: {type: node, produces: [x]}
  b: {type: node, produces: [y], consumes: [x]}
  c: {type: node, produces: [z], consumes: [x, y]}
)"),
                                                   "flow.yaml"),
                               {.sim_time = true, .enable_dds = false});
  std::atomic<bool> stop{false};
  app->start();
  app->run(kNsPerSec, stop);
  app->stop();
  // Same cycle: a writes 1, b reads it (2), c reads both (1 + 1 + 2 = 4).
  auto lease = app->context().channel<Meters>("z").acquire();
  ASSERT_TRUE(lease);
  EXPECT_DOUBLE_EQ(lease->value, 4.0);
  std::ostringstream text, dot;
  app->dataflow().print(text);
  EXPECT_NE(text.str().find("a --x [Meters]--> b, c\n"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("c --z [Meters]--> (no consumer)\n"), std::string::npos) << text.str();
  app->dataflow().print_dot(dot);
  EXPECT_NE(dot.str().find("\"a\" -> \"c\" [label=\"x\"];"), std::string::npos) << dot.str();
}

TEST(DataFlow, ConfigCheckDotOfTheMockRoverParsesWithGraphviz) {
#ifndef REGOLITH_EXE
  GTEST_SKIP() << "the regolith executable is not part of this build";
#else
  namespace fs = std::filesystem;
  if (std::system("command -v dot > /dev/null 2>&1") != 0)
    GTEST_FAIL() << "Graphviz `dot` missing: run deploy/setup.sh";
  const regolith::testing::TempDir tmp("flow");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const std::string cmd = std::string(REGOLITH_EXE) + " config check --dot > " + (dir / "flow.dot").string() + " 2> " +
                          (dir / "err.txt").string() + " && dot -Tsvg " + (dir / "flow.dot").string() + " -o " +
                          (dir / "flow.svg").string() + " 2>> " + (dir / "err.txt").string();
  const int rc = std::system(cmd.c_str());
  std::ifstream err(dir / "err.txt"), svg(dir / "flow.svg");
  std::stringstream e, s;
  e << err.rdbuf();
  s << svg.rdbuf();
  EXPECT_EQ(rc, 0) << e.str();
  EXPECT_TRUE(e.str().empty()) << e.str();  // dot prints warnings for a malformed graph
  // The mocked rover's chain: front camera -> sfs -> terrain/dtm -> sams, traversability.
  for (const char* want : {"terrain/dtm", "rock_probability", "camera front", "rate group terrain", "traversability"})
    EXPECT_NE(s.str().find(want), std::string::npos) << want;
#endif
}

// Command-line usage errors exit 2 (as configuration errors do) with one line naming the
// offending word; an unknown command gets a suggestion. Help and --version exit 0.
TEST(Cli, UsageErrorsExitTwoNamingTheWord) {
#ifndef REGOLITH_EXE
  GTEST_SKIP() << "the regolith executable is not part of this build";
#else
  namespace fs = std::filesystem;
  const regolith::testing::TempDir tmp("usage");  // removed whatever the outcome
  const fs::path err = tmp / "err.txt";
  auto run = [&](const std::string& args, std::string& text) {
    const int rc = std::system((std::string(REGOLITH_EXE) + " " + args + " > /dev/null 2> " + err.string()).c_str());
    std::ifstream in(err);
    std::stringstream ss;
    ss << in.rdbuf();
    text = ss.str();
    return WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  };
  std::string text;
  EXPECT_EQ(run("bogus", text), 2);
  EXPECT_NE(text.find("unknown command 'bogus'"), std::string::npos) << text;
  EXPECT_EQ(run("eval mapp", text), 2);
  EXPECT_NE(text.find("unknown command 'mapp' (did you mean 'map'?)"), std::string::npos) << text;
  EXPECT_EQ(run("run --duration -1", text), 2);
  EXPECT_NE(text.find("--duration: must be > 0 (got -1)"), std::string::npos) << text;
  EXPECT_LT(text.size(), 200u) << text;  // one short line, not the limits of a double
  EXPECT_EQ(run("rocks --method nonsense x.png --csv y.csv", text), 2);
  EXPECT_NE(text.find("nonsense"), std::string::npos) << text;
  EXPECT_EQ(run("--help", text), 0);
  EXPECT_EQ(run("--version", text), 0);
#endif
}
