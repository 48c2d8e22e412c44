// `regolith record` end to end (label integration, host only): this process publishes JointState,
// a latched GridMap and RockArray samples over loopback DDS; the `regolith` binary records them in
// a child process; the file is read back with regolith's McapReader (channels, schemas, counts)
// and decoded by an independent decoder (tests/record/mcap_js/decode.js: @mcap/core +
// @foxglove/rosmsg parse + @foxglove/rosmsg2-serialization MessageReader), whose fields must equal
// what was published.
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/recorder.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/msgs/ros2msg.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
namespace rt = regolith::testing;
namespace rd = regolith::dds;
namespace m = regolith::msgs;
using nlohmann::json;

constexpr int kJointStates = 40;
constexpr int kRockArrays = 3;

/// wait_for_readers() returns when our writers have matched the recorder's readers; the reverse
/// match (the reader accepting our writer) can come a little later, and a volatile reader drops
/// what a writer it does not know yet sent. No event of ours tells when that happened: wait a
/// discovery round trip on loopback.
void let_reader_match_writers() {
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
}

double joint_position(int i, int j) {
  return 0.01 * i + j;
}

}  // namespace

TEST(RecordDds, RecordsPublishedTopicsThatAnIndependentDecoderReads) {
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("record_" + ns);  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path file = dir / "rec.mcap";
  const fs::path log = dir / "record.log";

  rd::Participant pp({domain, ns});
  auto js = pp.make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::find_topic("joint_states")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 64},
      [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 3}); });
  auto map = pp.make_outbox<m::grid_map_msgs::GridMap>(
      "terrain/grid_map", rd::find_topic("terrain/grid_map")->writer_qos(),
      {.mode = rd::OutboxMode::kLatest, .slots = 2},
      [](m::grid_map_msgs::GridMap& g) { rd::reserve(g, {.layers = 2, .basic_layers = 1, .size_x = 3, .size_y = 2}); });
  auto rocks = pp.make_outbox<m::regolith_msgs::RockArray>(
      "terrain/rocks", rd::find_topic("terrain/rocks")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 8},
      [](m::regolith_msgs::RockArray& r) { rd::reserve(r, {.rocks = 2, .hypotheses = 1}); });
  pp.start();

  // The latched map first: the recorder's transient-local reader gets it when it joins.
  auto* g = map->begin();
  ASSERT_NE(g, nullptr);
  rd::set_time(g->header.stamp, 5 * regolith::kNsPerSec);
  rd::copy_string(g->header.frame_id, 32, "base_link");
  rd::set_length(g->layers, 2);
  rd::copy_string(g->layers._buffer[0], 32, "elevation");
  rd::copy_string(g->layers._buffer[1], 32, "traversability");
  rd::set_length(g->basic_layers, 1);
  rd::copy_string(g->basic_layers._buffer[0], 32, "elevation");
  rd::set_length(g->data, 2);
  g->info.resolution = 0.25;
  g->info.length_x = 0.75;
  g->info.length_y = 0.5;
  for (std::uint32_t l = 0; l < 2; ++l) {
    for (std::uint32_t i = 0; i < 6; ++i)
      g->data._buffer[l].data._buffer[i] = 0.5f * static_cast<float>(i) + static_cast<float>(l);
  }
  g->data._buffer[1].data._buffer[5] = std::nanf("");
  map->commit();

  const std::string exe = REGOLITH_EXE;
  const pid_t pid = rt::spawn({exe, "record", "joint_states", "terrain/grid_map", "terrain/rocks", "--out",
                               file.string(), "--domain", std::to_string(domain), "--namespace", ns, "--count",
                               std::to_string(kJointStates + kRockArrays + 1), "--duration", "60"},
                              log, {rt::Stderr::kSame});
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(pp.wait_for_readers({"joint_states", "terrain/grid_map", "terrain/rocks"}, 20 * regolith::kNsPerSec))
      << rt::read_file(log);
  let_reader_match_writers();

  for (int i = 0; i < kJointStates; ++i) {
    auto* s = js->begin();
    ASSERT_NE(s, nullptr);
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
    if (i < kRockArrays) {
      auto* r = rocks->begin();
      ASSERT_NE(r, nullptr);
      rd::set_time(r->header.stamp, (i + 1) * regolith::kNsPerMs);
      rd::copy_string(r->header.frame_id, 32, "front_optical_frame");
      rd::set_length(r->detections, 2);
      for (std::uint32_t k = 0; k < 2; ++k) {
        auto& d = r->detections._buffer[k];
        rd::set_length(d.results, 1);
        rd::copy_string(d.results._buffer[0].hypothesis.class_id, 32, "rock");
        d.results._buffer[0].hypothesis.score = 0.5 + 0.1 * k;
        d.bbox.center.position.x = 100.0 * i + k;
        d.bbox.center.position.y = 50.0 + k;
        d.bbox.size_x = 10.0 + k;
        d.bbox.size_y = 8.0;
        rd::copy_string(d.id, 32, ("r" + std::to_string(i) + "_" + std::to_string(k)).c_str());
      }
      rd::set_length(r->ground_range_m, 2);
      rd::set_length(r->lateral_offset_m, 2);
      rd::set_length(r->width_m, 2);
      rd::set_length(r->height_m, 2);
      rd::set_length(r->hazard, 2);
      for (std::uint32_t k = 0; k < 2; ++k) {
        r->ground_range_m._buffer[k] = 1.5 + i + k;
        r->lateral_offset_m._buffer[k] = -0.25 * k;
        r->width_m._buffer[k] = 0.1;
        r->height_m._buffer[k] = 0.05 + 0.1 * k;
        r->hazard._buffer[k] = k == 1;
      }
      rocks->commit();
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));  // a steady stream, not one burst
  }
  pp.wait_for_acks(5 * regolith::kNsPerSec);
  ASSERT_EQ(rt::wait_exit(pid, std::chrono::seconds(60)), 0) << rt::read_file(log);
  pp.stop();
  const std::string rec_log = rt::read_file(log);
  std::printf("%s", rec_log.c_str());

  // (a) regolith's reader: one channel per topic, one ros2msg schema per type, the counts.
  regolith::record::McapReader reader(file);
  const auto& info = reader.info();
  EXPECT_TRUE(info.from_summary);
  EXPECT_TRUE(info.problems.empty());
  EXPECT_EQ(info.profile, "ros2");
  std::map<std::string, std::uint64_t> counts;
  std::map<std::string, std::string> types;
  for (const auto& [id, ch] : info.channels) {
    EXPECT_EQ(ch.message_encoding, "cdr");
    const auto& schema = info.schemas.at(ch.schema_id);
    EXPECT_EQ(schema.encoding, "ros2msg");
    EXPECT_EQ(std::string(schema.data.begin(), schema.data.end()), m::ros2msg_definition(schema.name));
    // rosbag2's QoS metadata: the latched map transient-local (1), the streams volatile (2).
    const std::string qos = ch.metadata.count("offered_qos_profiles") ? ch.metadata.at("offered_qos_profiles") : "";
    EXPECT_NE(qos.find("reliability: 1\n"), std::string::npos) << ch.topic << ": " << qos;
    EXPECT_NE(qos.find(ch.topic.ends_with("grid_map") ? "durability: 1\n" : "durability: 2\n"), std::string::npos)
        << ch.topic << ": " << qos;
    counts[ch.topic] = info.message_counts.count(id) ? info.message_counts.at(id) : 0;
    types[ch.topic] = schema.name;
  }
  const std::string p = "/" + ns + "/";
  EXPECT_EQ(counts,
            (std::map<std::string, std::uint64_t>{
                {p + "joint_states", kJointStates}, {p + "terrain/grid_map", 1}, {p + "terrain/rocks", kRockArrays}}));
  EXPECT_EQ(types[p + "joint_states"], "sensor_msgs/msg/JointState");
  EXPECT_EQ(types[p + "terrain/grid_map"], "grid_map_msgs/msg/GridMap");
  EXPECT_EQ(types[p + "terrain/rocks"], "regolith_msgs/msg/RockArray");
  EXPECT_EQ(info.schemas.size(), 3u);
  std::size_t seen = 0;
  const auto problems = reader.for_each_message([&](const regolith::record::MessageView& mv) {
    ++seen;
    ASSERT_GE(mv.data.size(), 4u);
    EXPECT_EQ(mv.data[0], 0x00);  // CDR encapsulation header: plain CDR, little endian
    EXPECT_EQ(mv.data[1], 0x01);
    EXPECT_GT(mv.log_time, 1'600'000'000ULL * 1'000'000'000ULL);  // wall-clock ns
    EXPECT_GT(mv.publish_time, 1'600'000'000ULL * 1'000'000'000ULL);
    EXPECT_LE(mv.publish_time, mv.log_time + 1'000'000'000ULL);
  });
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(seen, static_cast<std::size_t>(kJointStates + kRockArrays + 1));

  // (b) the independent decoder.
  const fs::path decoded = dir / "decoded.jsonl";
  const std::string cmd = std::string("cd '") + REGOLITH_MCAP_JS_DIR + "' && '" + REGOLITH_NODE + "' decode.js '" +
                          file.string() + "' > '" + decoded.string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << rt::read_file(decoded);
  std::ifstream in(decoded);
  std::string line;
  int n_js = 0, n_map = 0, n_rocks = 0, n_channels = 0;
  while (std::getline(in, line)) {
    const json j = json::parse(line);
    if (j.contains("channel")) {
      ++n_channels;
      EXPECT_EQ(j["schema_encoding"], "ros2msg");
      continue;
    }
    const json& msg = j["message"];
    const std::string topic = j["topic"];
    if (topic == p + "joint_states") {
      const int i = n_js++;
      EXPECT_EQ(j["sequence"].get<int>(), i);
      EXPECT_EQ(msg["header"]["frame_id"], "base_link");
      EXPECT_EQ(msg["header"]["stamp"]["nanosec"].get<std::uint32_t>(),
                static_cast<std::uint32_t>((i + 1) * 1'000'000));
      ASSERT_EQ(msg["name"].size(), 3u);
      for (int k = 0; k < 3; ++k) {
        EXPECT_EQ(msg["name"][k], "wheel_" + std::to_string(k));
        EXPECT_EQ(msg["position"][k].get<double>(), joint_position(i, k));
        EXPECT_EQ(msg["velocity"][k].get<double>(), -joint_position(i, k));
      }
      EXPECT_TRUE(msg["effort"].empty());
    } else if (topic == p + "terrain/grid_map") {
      ++n_map;
      EXPECT_EQ(msg["header"]["stamp"]["sec"], 5);
      EXPECT_EQ(msg["layers"], json::array({"elevation", "traversability"}));
      EXPECT_EQ(msg["basic_layers"], json::array({"elevation"}));
      EXPECT_EQ(msg["info"]["resolution"].get<double>(), 0.25);
      EXPECT_EQ(msg["info"]["pose"]["orientation"]["w"].get<double>(), 1.0);
      ASSERT_EQ(msg["data"].size(), 2u);
      EXPECT_EQ(msg["data"][0]["layout"]["dim"][0]["label"], "column_index");
      EXPECT_EQ(msg["data"][0]["layout"]["dim"][0]["size"], 2);
      EXPECT_EQ(msg["data"][0]["layout"]["dim"][1]["size"], 3);
      for (int l = 0; l < 2; ++l) {
        ASSERT_EQ(msg["data"][l]["data"].size(), 6u);
        for (int i = 0; i < 6; ++i) {
          if (l == 1 && i == 5) {
            EXPECT_TRUE(msg["data"][l]["data"][i].is_null());  // NaN (JSON null)
          } else {
            EXPECT_EQ(msg["data"][l]["data"][i].get<double>(), 0.5 * i + l);
          }
        }
      }
    } else if (topic == p + "terrain/rocks") {
      const int i = n_rocks++;
      EXPECT_EQ(msg["header"]["frame_id"], "front_optical_frame");
      ASSERT_EQ(msg["detections"].size(), 2u);
      for (int k = 0; k < 2; ++k) {
        const json& d = msg["detections"][k];
        EXPECT_EQ(d["id"], "r" + std::to_string(i) + "_" + std::to_string(k));
        EXPECT_EQ(d["results"][0]["hypothesis"]["class_id"], "rock");
        EXPECT_DOUBLE_EQ(d["results"][0]["hypothesis"]["score"].get<double>(), 0.5 + 0.1 * k);
        EXPECT_EQ(d["results"][0]["pose"]["covariance"].size(), 36u);
        EXPECT_EQ(d["bbox"]["center"]["position"]["x"].get<double>(), 100.0 * i + k);
        EXPECT_EQ(d["bbox"]["size_x"].get<double>(), 10.0 + k);
        EXPECT_DOUBLE_EQ(msg["ground_range_m"][k].get<double>(), 1.5 + i + k);
        EXPECT_DOUBLE_EQ(msg["height_m"][k].get<double>(), 0.05 + 0.1 * k);
        EXPECT_EQ(msg["hazard"][k].get<bool>(), k == 1);
      }
    } else {
      ADD_FAILURE() << "unexpected topic " << topic;
    }
  }
  EXPECT_EQ(n_channels, 3);
  EXPECT_EQ(n_js, kJointStates);
  EXPECT_EQ(n_map, 1);
  EXPECT_EQ(n_rocks, kRockArrays);
}

TEST(RecordDds, CtrlCClosesTheFileWithItsSummary) {
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("record_" + ns);  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path file = dir / "sigint.mcap";
  const fs::path log = dir / "record.log";
  rd::Participant pp({domain, ns});
  auto js = pp.make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::find_topic("joint_states")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 16},
      [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 1}); });
  pp.start();
  const pid_t pid =
      rt::spawn({std::string(REGOLITH_EXE), "record", "joint_states", "/diagnostics", "--out", file.string(),
                 "--domain", std::to_string(domain), "--namespace", ns, "--no-compression"},
                log, {rt::Stderr::kSame});
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(pp.wait_for_readers({"joint_states"}, 20 * regolith::kNsPerSec)) << rt::read_file(log);
  let_reader_match_writers();
  for (int i = 0; i < 5; ++i) {
    auto* s = js->begin();
    ASSERT_NE(s, nullptr);
    rd::set_length(s->name, 1);
    rd::copy_string(s->name._buffer[0], 32, "wheel");
    js->commit();
  }
  // Acknowledged = in the recorder's reader cache: it takes them before closing, even when the
  // signal arrives first.
  ASSERT_TRUE(pp.wait_for_acks(5 * regolith::kNsPerSec));
  kill(pid, SIGINT);
  ASSERT_EQ(rt::wait_exit(pid, std::chrono::seconds(20)), 0) << rt::read_file(log);
  pp.stop();
  regolith::record::McapReader reader(file);
  EXPECT_TRUE(reader.info().from_summary);  // footer + summary written on Ctrl-C
  EXPECT_FALSE(reader.info().truncated);
  EXPECT_EQ(reader.info().channels.size(), 2u);
  EXPECT_EQ(reader.info().message_count, 5u) << rt::read_file(log);
  EXPECT_EQ(reader.info().chunks.size(), 1u);
  EXPECT_EQ(reader.info().chunks[0].compression, "");
}

TEST(RecordDds, UseSimTimeLogsSamplesAtTheWritersSimulatedSourceTime) {
  // A publisher on simulated time (Participant::set_source_clock, as `regolith run --sim-time`
  // sets it) stamps each sample with its simulated ROS time as it is written; `regolith record
  // --use-sim-time` logs it there, so the file plays on the simulated time line.
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("record_" + ns);  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path file = dir / "sim.mcap";
  const fs::path log = dir / "record.log";
  std::atomic<regolith::TimeNs> sim_now{regolith::kNsPerSec};
  rd::Participant pp({domain, ns});
  pp.set_source_clock([&sim_now] { return sim_now.load(); });
  auto js = pp.make_outbox<m::sensor_msgs::JointState>(
      "joint_states", rd::find_topic("joint_states")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 16},
      [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 1}); });
  pp.start();
  constexpr int kSamples = 8;
  const pid_t pid = rt::spawn(
      {std::string(REGOLITH_EXE), "record", "joint_states", "--out", file.string(), "--domain", std::to_string(domain),
       "--namespace", ns, "--use-sim-time", "--count", std::to_string(kSamples), "--duration", "60"},
      log, {rt::Stderr::kSame});
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(pp.wait_for_readers({"joint_states"}, 20 * regolith::kNsPerSec)) << rt::read_file(log);
  let_reader_match_writers();
  for (int i = 0; i < kSamples; ++i) {
    sim_now.store(regolith::kNsPerSec + i * 20 * regolith::kNsPerMs);  // the cycle's simulated time
    auto* s = js->begin();
    ASSERT_NE(s, nullptr);
    rd::set_time(s->header.stamp, sim_now.load());
    rd::set_length(s->name, 1);
    rd::copy_string(s->name._buffer[0], 32, "wheel");
    js->commit();
    ASSERT_TRUE(pp.drain(5 * regolith::kNsPerSec));  // written before simulated time moves on
  }
  ASSERT_TRUE(pp.wait_for_acks(5 * regolith::kNsPerSec));
  ASSERT_EQ(rt::wait_exit(pid, std::chrono::seconds(60)), 0) << rt::read_file(log);
  pp.stop();
  regolith::record::McapReader reader(file);
  EXPECT_EQ(reader.info().message_count, static_cast<std::uint64_t>(kSamples)) << rt::read_file(log);
  EXPECT_EQ(reader.info().message_start_time, 1'000'000'000u);
  EXPECT_EQ(reader.info().message_end_time, 1'140'000'000u);
  const auto problems = reader.for_each_message([&](const regolith::record::MessageView& mv) {
    EXPECT_EQ(mv.log_time, 1'000'000'000u + 20'000'000ull * mv.sequence) << "sample " << mv.sequence;
    EXPECT_EQ(mv.publish_time, mv.log_time) << "sample " << mv.sequence;
  });
  EXPECT_TRUE(problems.empty());
}

TEST(RecordDds, SimLogTimeKeepsSimulatedWritersAndPutsWallWritersOnTheClock) {
  constexpr std::uint64_t kWall = 1'764'000'000'000'000'000ull;  // receipt: wall time, 2025-11
  // No /clock yet: the source time, whatever it is.
  EXPECT_EQ(rd::sim_log_time(5'000, -1, kWall), 5'000u);
  EXPECT_EQ(rd::sim_log_time(kWall, -1, kWall), kWall);
  // A simulated writer (source time near the clock, also ahead of it: a fast run) keeps its time.
  EXPECT_EQ(rd::sim_log_time(3'000'000'000ull, 2'000'000'000, kWall), 3'000'000'000ull);
  // A wall-time writer is logged at the newest clock.
  EXPECT_EQ(rd::sim_log_time(kWall - 1'000, 2'000'000'000, kWall), 2'000'000'000ull);
  // A replay on the time line of a recording made a day ago: the same split.
  const std::int64_t yesterday = static_cast<std::int64_t>(kWall) - 86'400'000'000'000;
  EXPECT_EQ(rd::sim_log_time(yesterday + 5, yesterday, kWall), static_cast<std::uint64_t>(yesterday + 5));
  EXPECT_EQ(rd::sim_log_time(kWall - 2'000'000, yesterday, kWall), static_cast<std::uint64_t>(yesterday));
}

// A regolith run on simulated time (source clock set, /clock published) and a ROS 2-style node on
// the wall clock publishing the same topic: `regolith record --use-sim-time` puts both on the
// simulated time line, with /clock recorded or not.
void record_sim_and_wall_writers(bool record_clock) {
  rd::testing::use_loopback_config();
  const std::uint32_t domain = rd::testing::test_domain();
  const std::string ns = rd::testing::unique_ns();
  const regolith::testing::TempDir tmp("record_" + ns);  // removed whatever the outcome
  const fs::path file = tmp.path() / "mixed.mcap";
  const fs::path log = tmp.path() / "record.log";
  std::atomic<regolith::TimeNs> sim_now{regolith::kNsPerSec};
  rd::Participant sim({domain, ns});
  sim.set_source_clock([&sim_now] { return sim_now.load(); });
  rd::Participant wall({domain, ns});
  const auto joint_states = [](rd::Participant& p) {
    return p.make_outbox<m::sensor_msgs::JointState>(
        "joint_states", rd::find_topic("joint_states")->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 16},
        [](m::sensor_msgs::JointState& s) { rd::reserve(s, {.joints = 1}); });
  };
  auto sim_js = joint_states(sim);
  auto wall_js = joint_states(wall);
  auto clock = sim.make_outbox<m::rosgraph_msgs::Clock>("/clock", rd::find_topic("/clock")->writer_qos(),
                                                        {.mode = rd::OutboxMode::kFifo, .slots = 16},
                                                        [](m::rosgraph_msgs::Clock&) {});
  sim.start();
  wall.start();
  constexpr int kSteps = 3;
  const int samples = 2 * kSteps + (record_clock ? kSteps : 0);
  std::vector<std::string> args = {std::string(REGOLITH_EXE),
                                   "record",
                                   "joint_states",
                                   "--out",
                                   file.string(),
                                   "--domain",
                                   std::to_string(domain),
                                   "--namespace",
                                   ns,
                                   "--use-sim-time",
                                   "--count",
                                   std::to_string(samples),
                                   "--duration",
                                   "60"};
  if (record_clock) args.insert(args.begin() + 3, "/clock");
  const pid_t pid = rt::spawn(args, log, {rt::Stderr::kSame});
  ASSERT_GT(pid, 0);
  ASSERT_TRUE(sim.wait_for_readers({"joint_states", "/clock"}, 20 * regolith::kNsPerSec)) << rt::read_file(log);
  ASSERT_TRUE(wall.wait_for_readers({"joint_states"}, 20 * regolith::kNsPerSec)) << rt::read_file(log);
  let_reader_match_writers();
  const auto publish = [](auto& out, regolith::TimeNs stamp) {
    auto* s = out->begin();
    ASSERT_NE(s, nullptr);
    rd::set_time(s->header.stamp, stamp);
    rd::set_length(s->name, 1);
    rd::copy_string(s->name._buffer[0], 32, "wheel");
    out->commit();
  };
  for (int i = 0; i < kSteps; ++i) {
    sim_now.store(regolith::kNsPerSec + i * 20 * regolith::kNsPerMs);
    auto* c = clock->begin();
    ASSERT_NE(c, nullptr);
    rd::set_time(c->clock, sim_now.load());
    clock->commit();
    ASSERT_TRUE(sim.wait_for_acks(5 * regolith::kNsPerSec));  // in the recorder's cache before the samples
    publish(sim_js, sim_now.load());
    ASSERT_TRUE(sim.wait_for_acks(5 * regolith::kNsPerSec));
    publish(wall_js, sim_now.load());  // a ROS 2 node's header stamp follows /clock; its DDS stamp is wall time
    ASSERT_TRUE(wall.wait_for_acks(5 * regolith::kNsPerSec));
  }
  ASSERT_EQ(rt::wait_exit(pid, std::chrono::seconds(60)), 0) << rt::read_file(log);
  sim.stop();
  wall.stop();
  const std::string out = rt::read_file(log);
  EXPECT_NE(out.find(std::to_string(kSteps) + " sample(s) of writers on wall time logged at the newest /clock"),
            std::string::npos)
      << out;
  regolith::record::McapReader reader(file);
  EXPECT_EQ(reader.info().message_count, static_cast<std::uint64_t>(samples)) << out;
  EXPECT_EQ(reader.info().message_start_time, 1'000'000'000u);
  EXPECT_EQ(reader.info().message_end_time, 1'040'000'000u);
  int from_sim = 0, from_wall = 0;
  const std::uint64_t wall_before = static_cast<std::uint64_t>(regolith::realtime_now()) - 600 * regolith::kNsPerSec;
  const auto problems = reader.for_each_message([&](const regolith::record::MessageView& mv) {
    if (mv.publish_time > wall_before) {
      // The wall-time writer: logged at the newest clock the recorder had when it took the sample,
      // the clock of its step or, when the recorder took it late (a slow machine, sanitizers), of
      // a later step: one of the clock values published, never before its own step's.
      ++from_wall;
      const std::uint64_t step = 1'000'000'000u + 20'000'000ull * (from_wall - 1);
      EXPECT_GE(mv.log_time, step) << "wall sample " << from_wall;
      EXPECT_LE(mv.log_time, 1'000'000'000u + 20'000'000ull * (kSteps - 1)) << "wall sample " << from_wall;
      EXPECT_EQ((mv.log_time - 1'000'000'000u) % 20'000'000u, 0u) << "wall sample " << from_wall << " between clocks";
    } else {  // the run on simulated time (and /clock itself): its own source time
      ++from_sim;
      EXPECT_EQ(mv.log_time, mv.publish_time);
    }
  });
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(from_wall, kSteps);
  EXPECT_EQ(from_sim, samples - kSteps);
}

TEST(RecordDds, UseSimTimePutsWallClockWritersOnTheNewestClock) {
  record_sim_and_wall_writers(false);
}

TEST(RecordDds, UseSimTimeWithClockRecordedLogsItOnItsOwnTime) {
  record_sim_and_wall_writers(true);
}

TEST(RecordDds, UsageErrorsExitTwoNamingTheProblem) {
  const regolith::testing::TempDir tmp("record_" + rd::testing::unique_ns());  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path log = dir / "record.log";
  const std::string exe = REGOLITH_EXE;
  pid_t pid = rt::spawn({exe, "record", "joint_state", "--out", (dir / "x.mcap").string()}, log, {rt::Stderr::kSame});
  EXPECT_EQ(rt::wait_exit(pid, std::chrono::seconds(20)), 2);
  EXPECT_NE(rt::read_file(log).find("unknown topic 'joint_state'"), std::string::npos) << rt::read_file(log);
  EXPECT_FALSE(fs::exists(dir / "x.mcap"));
  pid = rt::spawn({exe, "record", "--out", (dir / "x.mcap").string()}, log, {rt::Stderr::kSame});
  EXPECT_EQ(rt::wait_exit(pid, std::chrono::seconds(20)), 2);
  EXPECT_NE(rt::read_file(log).find("no topic given"), std::string::npos) << rt::read_file(log);
  pid = rt::spawn({exe, "record", "joint_states"}, log, {rt::Stderr::kSame});
  EXPECT_EQ(rt::wait_exit(pid, std::chrono::seconds(20)), 2);
  EXPECT_NE(rt::read_file(log).find("--out"), std::string::npos) << rt::read_file(log);
  pid = rt::spawn({exe, "record", "joint_states", "--out", (dir / "x.mcap").string(), "--zstd", "--no-compression"},
                  log, {rt::Stderr::kSame});
  EXPECT_EQ(rt::wait_exit(pid, std::chrono::seconds(20)), 2);
}

TEST(RecordDds, FoxgloveParsesTheSchemaOfEveryRosType) {
  // One channel per embedded type (no messages): decode.js builds a MessageReader from each
  // schema with @foxglove/rosmsg's parser, so every definition (constants, defaults, relative
  // names) must parse.
  const regolith::testing::TempDir tmp("record_" + rd::testing::unique_ns());  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path file = dir / "schemas.mcap";
  const auto types = m::ros2msg_types();
  {
    regolith::record::McapWriter w(file);
    for (const auto t : types) {
      const std::string name(t);
      const std::string ros_type = name.substr(0, name.find('/')) + "/msg/" + name.substr(name.find('/') + 1);
      const auto s = w.add_schema(ros_type, "ros2msg", m::ros2msg_definition(ros_type));
      w.add_channel(s, "/" + name, "cdr");
    }
    w.close();
  }
  const fs::path decoded = dir / "decoded.jsonl";
  const std::string cmd = std::string("cd '") + REGOLITH_MCAP_JS_DIR + "' && '" + REGOLITH_NODE + "' decode.js '" +
                          file.string() + "' > '" + decoded.string() + "' 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << rt::read_file(decoded);
  std::ifstream in(decoded);
  std::string line;
  std::size_t channels = 0;
  while (std::getline(in, line)) channels += json::parse(line).contains("channel") ? 1 : 0;
  EXPECT_EQ(channels, types.size());
  EXPECT_EQ(types.size(), 47u);
}
