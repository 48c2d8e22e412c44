// Helper process for test_dds_process: publishes on a given domain / namespace
//   dds_test_publisher <domain> <namespace> <samples> <period_ms>
// one latched terrain/grid_map at start, then <samples> joint_states (stamps 1
// s, 2 s, ...) and diagnostics every <period_ms>, through the same Outbox path
// the runtime uses. Exits 0 when done.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/topics.hpp"

namespace rd = regolith::dds;
namespace m = regolith::msgs;

int main(int argc, char** argv) {
  if (argc != 5) {
    std::fprintf(stderr, "usage: %s <domain> <namespace> <samples> <period_ms>\n", argv[0]);
    return 2;
  }
  try {
    const auto domain = static_cast<std::uint32_t>(std::stoul(argv[1]));
    const int samples = std::stoi(argv[3]);
    const int period_ms = std::stoi(argv[4]);
    rd::Participant pp({domain, argv[2]});
    auto js = pp.make_outbox<m::sensor_msgs::JointState>(
        "joint_states", rd::find_topic("joint_states")->writer_qos(), {},
        [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 2}); });
    auto diag = pp.make_outbox<m::diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", rd::find_topic("diagnostics")->writer_qos(), {},
        [](m::diagnostic_msgs::DiagnosticArray& a) { rd::reserve(a, {.statuses = 1, .values_per_status = 1}); });
    auto map = pp.make_outbox<m::grid_map_msgs::GridMap>(
        "terrain/grid_map", rd::find_topic("terrain/grid_map")->writer_qos(),
        {.mode = rd::OutboxMode::kLatest, .slots = 2}, [](m::grid_map_msgs::GridMap& g) {
          rd::reserve(g, {.layers = 1, .basic_layers = 1, .size_x = 2, .size_y = 2});
        });
    pp.start();
    if (auto* g = map->begin()) {
      rd::set_length(g->layers, 1);
      rd::copy_string(g->layers._buffer[0], 32, "elevation");
      rd::set_length(g->data, 1);
      for (std::uint32_t i = 0; i < 4; ++i) g->data._buffer[0].data._buffer[i] = 0.5f * static_cast<float>(i);
      g->info.resolution = 0.25;
      map->commit();
    }
    for (int i = 0; i < samples; ++i) {
      if (auto* s = js->begin()) {
        rd::set_time(s->header.stamp, (i + 1) * regolith::kNsPerSec);
        rd::set_length(s->name, 2);
        rd::copy_string(s->name._buffer[0], 32, "wheel_left");
        rd::copy_string(s->name._buffer[1], 32, "wheel_right");
        rd::set_length(s->position, 2);
        s->position._buffer[0] = 0.1 * i;
        s->position._buffer[1] = -0.1 * i;
        js->commit();
      }
      if (auto* a = diag->begin()) {
        rd::set_time(a->header.stamp, (i + 1) * regolith::kNsPerSec);
        rd::set_length(a->status, 1);
        rd::copy_string(a->status._buffer[0].name, 64, "publisher: heartbeat");
        rd::set_length(a->status._buffer[0].values, 1);
        rd::copy_string(a->status._buffer[0].values._buffer[0].key, 64, "count");
        rd::format_int(a->status._buffer[0].values._buffer[0].value, 64, i);
        diag->commit();
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(period_ms));
    }
    pp.stop();
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "dds_test_publisher: %s\n", e.what());
    return 1;
  }
}
