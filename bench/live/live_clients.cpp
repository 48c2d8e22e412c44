// What watching costs the rover (issue 19's goals): the mocked rover in real time with the
// Foxglove WebSocket server relaying every DDS topic (`regolith run --live`), run twice in one
// process: with no client (the peer), then with 4 clients subscribed to every channel and reading
// as fast as they can. Printed: the rate groups' CPU (the members' step() thread CPU time) of each
// run and their ratio (goal < 1.05), heap allocations inside cycles with the clients (goal 0), the
// whole process's CPU (server, relay and DDS threads included), and per topic the latency from a
// message's header stamp (the camera frame's capture time for the vision topics, ROS time) to its
// arrival at a client, p50 / p99 (goal p99 <= 150 ms capture to pixels; a browser adds decoding
// and painting, a few ms for a 320x240 JPEG).
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <map>
#include <memory>
#include <mutex>
#include <new>
#include <string>
#include <thread>
#include <vector>

#include <sys/resource.h>

#include <benchmark/benchmark.h>
#include <nlohmann/json.hpp>

#include "cli_support.hpp"
#include "regolith/live/dds_relay.hpp"
#include "regolith/live/foxglove_server.hpp"
#include "regolith/runtime/application.hpp"
#include "ws_test_client.hpp"

#define REGOLITH_ALLOC_COUNT_CYCLES
#include "alloc_counter.hpp"  // the one TU of this binary that replaces operator new

using namespace regolith;
using nlohmann::json;

namespace {

constexpr int kWarmupS = 6, kMeasureS = 20, kClients = 4;

/// Sum of the members' step() CPU time (ns) so far.
double members_cpu_ns(const runtime::Application& app) {
  double ns = 0;
  for (const auto* c : app.view().components) {
    const auto s = c->cpu().summary();
    ns += static_cast<double>(s.mean) * static_cast<double>(s.count);
  }
  return ns;
}

double process_cpu_s() {
  rusage u{};
  getrusage(RUSAGE_SELF, &u);
  return static_cast<double>(u.ru_utime.tv_sec + u.ru_stime.tv_sec) +
         1e-6 * static_cast<double>(u.ru_utime.tv_usec + u.ru_stime.tv_usec);
}

std::int64_t realtime_ns() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return static_cast<std::int64_t>(t.tv_sec) * 1000000000LL + t.tv_nsec;
}

/// Messages that start with a std_msgs/Header (or a stamp): header.stamp from the CDR payload.
bool stamp_of(const std::string& frame, std::int64_t& stamp_ns) {
  if (frame.size() < 13 + 4 + 8) return false;
  const unsigned char* p = reinterpret_cast<const unsigned char*>(frame.data()) + 13;
  if (p[0] != 0 || p[1] != 1) return false;  // little-endian plain CDR only
  std::int32_t sec = 0;
  std::uint32_t nsec = 0;
  std::memcpy(&sec, p + 4, 4);
  std::memcpy(&nsec, p + 8, 4);
  stamp_ns = static_cast<std::int64_t>(sec) * 1000000000LL + nsec;
  return true;
}

struct Latencies {
  std::mutex m;
  std::map<std::string, std::vector<double>> ms;  // topic -> latencies
};

/// A client subscribed to every channel, reading until `stop`; records latencies of stamped topics.
void client_loop(std::uint16_t port, const std::atomic<bool>& stop, Latencies& out, std::atomic<std::uint64_t>& bytes) {
  live::testing::WsClient c(port, live::kSubprotocol);
  if (!c.ok()) return;
  std::map<std::uint32_t, std::string> by_sub;
  std::map<std::string, std::vector<double>> mine;
  const std::vector<std::string> stamped = {"joint_states",
                                            "terrain/rocks",
                                            "terrain/wheel_sinkage",
                                            "preview/rocks/compressed",
                                            "preview/sinkage/compressed",
                                            "odom",
                                            "terrain/grid_map"};
  while (!stop.load()) {
    auto f = c.read(200);
    if (!f) continue;
    if (f->opcode == 1) {
      const json j = json::parse(f->payload, nullptr, false);
      if (j.is_object() && j.value("op", "") == "advertise") {
        json subs = json::array();
        for (const json& ch : j.at("channels")) {
          const std::uint32_t id = ch.at("id").get<std::uint32_t>();
          const std::string topic = ch.at("topic").get<std::string>();
          for (const auto& s : stamped)
            if (topic.size() >= s.size() && topic.compare(topic.size() - s.size(), s.size(), s) == 0 &&
                (topic.size() == s.size() || topic[topic.size() - s.size() - 1] == '/'))
              by_sub[id + 1000] = s;
          subs.push_back({{"id", id + 1000}, {"channelId", id}});
        }
        c.send_text(json{{"op", "subscribe"}, {"subscriptions", subs}}.dump());
      }
      continue;
    }
    if (f->opcode != 2 || f->payload.size() < 13 || static_cast<unsigned char>(f->payload[0]) != 0x01) continue;
    bytes.fetch_add(f->payload.size(), std::memory_order_relaxed);
    std::uint32_t sub = 0;
    std::memcpy(&sub, f->payload.data() + 1, 4);
    const auto it = by_sub.find(sub);
    std::int64_t stamp = 0;
    if (it != by_sub.end() && stamp_of(f->payload, stamp))
      mine[it->second].push_back(static_cast<double>(realtime_ns() - stamp) * 1e-6);
  }
  std::lock_guard<std::mutex> lock(out.m);
  for (auto& [t, v] : mine) out.ms[t].insert(out.ms[t].end(), v.begin(), v.end());
}

struct RunResult {
  double members_cpu_s = 0, process_cpu_s = 0;
  std::uint64_t cycles = 0, allocs = 0, slips = 0, bytes = 0;
};

RunResult run_rover(int clients, Latencies& lat) {
  auto app =
      runtime::Application::load(Params::load_string(cli::embedded_mock_rover(), "<embedded>/config/mock_rover.yaml"),
                                 {.sim_time = false, .enable_dds = true});
  live::FoxgloveServerOptions opt;
  opt.port = 0;
  live::DdsRelay relay(*app->dds(), opt);
  relay.start();
  std::atomic<bool> stop{false}, stop_clients{false};
  std::atomic<std::uint64_t> bytes{0};
  std::vector<std::thread> threads;
  for (int k = 0; k < clients; ++k)
    threads.emplace_back([&] { client_loop(relay.server().port(), stop_clients, lat, bytes); });
  app->start();
  app->run(static_cast<TimeNs>(kWarmupS) * kNsPerSec, stop);
  auto cycles = [&] {
    std::uint64_t n = 0, s = 0;
    for (const auto* g : app->view().groups) n += g->counters().cycles, s += g->counters().slips;
    return std::pair{n, s};
  };
  const double cpu0 = members_cpu_ns(*app), p0 = process_cpu_s();
  const auto [c0, s0] = cycles();
  const std::uint64_t a0 = regolith::testing::cycle_allocations();
  {
    std::lock_guard<std::mutex> lock(lat.m);
    lat.ms.clear();  // latencies of the measured window only
  }
  app->run(static_cast<TimeNs>(kMeasureS) * kNsPerSec, stop);
  RunResult r;
  r.members_cpu_s = (members_cpu_ns(*app) - cpu0) * 1e-9;
  r.process_cpu_s = process_cpu_s() - p0;
  const auto [c1, s1] = cycles();
  r.cycles = c1 - c0;
  r.slips = s1 - s0;
  r.allocs = regolith::testing::cycle_allocations() - a0;
  stop_clients = true;
  for (auto& t : threads) t.join();
  r.bytes = bytes.load();
  app->stop();
  relay.stop();
  return r;
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size() - 1) + 0.5))];
}

void BM_LiveClients(benchmark::State& state) {
  cli::register_everything();
  for (auto _ : state) {
    Latencies none, four;
    const RunResult a = run_rover(0, none);
    const RunResult b = run_rover(kClients, four);
    const double ratio = a.members_cpu_s > 0 ? b.members_cpu_s / a.members_cpu_s : 0.0;
    state.counters["cpu_ratio"] = ratio;
    state.counters["allocs_in_cycles"] = static_cast<double>(b.allocs);
    std::printf("\nmocked rover, real time, %d s measured after %d s warm-up, every topic relayed:\n", kMeasureS,
                kWarmupS);
    std::printf("  rate groups' CPU (members' step): no client %.3f s, %d clients %.3f s -> ratio %.3f (goal < 1.05)\n",
                a.members_cpu_s, kClients, b.members_cpu_s, ratio);
    std::printf("  whole process CPU: %.2f s vs %.2f s (server, relay, DDS and client threads included)\n",
                a.process_cpu_s, b.process_cpu_s);
    std::printf("  cycles %llu vs %llu, slips %llu vs %llu, allocations inside cycles with clients: %llu (goal 0)\n",
                static_cast<unsigned long long>(a.cycles), static_cast<unsigned long long>(b.cycles),
                static_cast<unsigned long long>(a.slips), static_cast<unsigned long long>(b.slips),
                static_cast<unsigned long long>(b.allocs));
    std::printf("  sent to the clients: %.1f MB; latency header stamp -> client, per topic (all %d clients):\n",
                static_cast<double>(b.bytes) * 1e-6, kClients);
    double worst = 0;
    for (const auto& [topic, v] : four.ms) {
      const double p99 = percentile(v, 0.99);
      std::printf("    %-28s n %5zu  p50 %7.1f ms  p99 %7.1f ms\n", topic.c_str(), v.size(), percentile(v, 0.5), p99);
      if (topic.rfind("preview/", 0) == 0 || topic == "terrain/rocks" || topic == "terrain/wheel_sinkage")
        worst = std::max(worst, p99);
    }
    std::printf("  camera-derived topics, worst p99: %.1f ms (goal <= 150 ms capture to pixels)\n", worst);
    state.counters["camera_p99_ms"] = worst;
  }
}
BENCHMARK(BM_LiveClients)->Iterations(1)->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
