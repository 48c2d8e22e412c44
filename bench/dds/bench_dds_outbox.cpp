// Cost on the calling (real-time) thread of handing a JointState to DDS through
// an Outbox (begin / fill / commit; the publisher thread does dds_write)
// against calling dds_write directly on that thread (the peer), with one
// matched in-process reader. Prints the ratio.
#include <cstdio>
#include <map>
#include <memory>
#include <string>

#include <unistd.h>

#include <benchmark/benchmark.h>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/topics.hpp"

namespace rd = regolith::dds;
namespace m = regolith::msgs;

namespace {

void fill(m::sensor_msgs::JointState& js, std::int64_t i) {
  rd::set_time(js.header.stamp, i * 10'000'000);
  rd::copy_string(js.header.frame_id, 32, "base_link");
  static const char* const kNames[4] = {"wheel_fl", "wheel_fr", "wheel_rl", "wheel_rr"};
  rd::set_length(js.name, 4);
  rd::set_length(js.position, 4);
  rd::set_length(js.velocity, 4);
  for (std::uint32_t k = 0; k < 4; ++k) {
    rd::copy_string(js.name._buffer[k], 32, kNames[k]);
    js.position._buffer[k] = 0.001 * static_cast<double>(i + k);
    js.velocity._buffer[k] = 1.0;
  }
}

struct Fixture {
  Fixture() : pp({150u + static_cast<std::uint32_t>(getpid()) % 50u, "bench" + std::to_string(getpid())}) {
    reader = std::make_unique<rd::Reader<m::sensor_msgs::JointState>>(
        pp, "joint_states", rd::QosProfile::reader(rd::Reliability::kBestEffort, rd::Durability::kVolatile, 1));
  }
  rd::Participant pp;
  std::unique_ptr<rd::Reader<m::sensor_msgs::JointState>> reader;
};

void BM_OutboxCommit(benchmark::State& state) {
  Fixture f;
  auto box = f.pp.make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::QosProfile::stream(10), {.mode = rd::OutboxMode::kFifo, .slots = 64},
      [](m::sensor_msgs::JointState& js) { rd::reserve(js, {.joints = 4}); });
  f.pp.start();
  std::int64_t i = 0;
  for (auto _ : state) {
    if (auto* js = box->begin()) {
      fill(*js, i++);
      box->commit();
    }
    if ((i & 31) == 0) {
      state.PauseTiming();  // keep the publisher from falling behind; not part
                            // of the RT cost
      f.pp.drain(1'000'000'000);
      state.ResumeTiming();
    }
  }
  f.pp.stop();
  state.counters["dropped"] = static_cast<double>(box->dropped());
}

void BM_DirectWrite(benchmark::State& state) {
  Fixture f;
  m::sensor_msgs::JointState js{};
  rd::reserve(js, {.joints = 4});
  const rd::Qos q(rd::QosProfile::stream(10), rd::Qos::For::kWriter);
  const dds_entity_t w = dds_create_writer(
      f.pp.handle(), f.pp.topic("joint_states", rd::MsgTraits<m::sensor_msgs::JointState>::descriptor()), q.get(),
      nullptr);
  std::int64_t i = 0;
  for (auto _ : state) {
    fill(js, i++);
    benchmark::DoNotOptimize(dds_write(w, &js));
  }
  rd::free_contents(rd::MsgTraits<m::sensor_msgs::JointState>::descriptor(), &js);
}

BENCHMARK(BM_OutboxCommit)->MinTime(0.5);
BENCHMARK(BM_DirectWrite)->MinTime(0.5);

class RatioReporter : public benchmark::ConsoleReporter {
 public:
  void ReportRuns(const std::vector<Run>& runs) override {
    for (const auto& r : runs) ns_[r.benchmark_name()] = r.GetAdjustedRealTime();
    ConsoleReporter::ReportRuns(runs);
  }
  std::map<std::string, double> ns_;
};

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  RatioReporter rep;
  benchmark::RunSpecifiedBenchmarks(&rep);
  const auto a = rep.ns_.find("BM_OutboxCommit/min_time:0.500");
  const auto b = rep.ns_.find("BM_DirectWrite/min_time:0.500");
  if (a != rep.ns_.end() && b != rep.ns_.end() && b->second > 0)
    std::printf(
        "RT-thread wall time per sample, outbox commit / direct "
        "dds_write: %.3f (%.0f ns vs %.0f ns)\n",
        a->second / b->second, a->second, b->second);
  benchmark::Shutdown();
  return 0;
}
