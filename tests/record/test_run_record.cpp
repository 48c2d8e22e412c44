// `regolith run --record FILE` / the `record:` block: the mocked rover (config/mock_rover.yaml on a
// test-unique DDS domain and namespace) runs under --sim-time as a child process while recording
// every DDS topic it publishes in the same process (dds::DdsRecorder on the application's
// participant). McapReader must find the deployment YAML as an attachment, the `regolith`
// metadata, one channel per topic with exactly the count the run's DDS summary says was published,
// log times non-decreasing per channel; `regolith log info` reads the file. Config errors: a
// `record:` block with DDS disabled names record.file; an unknown record key is located. With node:
// tests/record/mcap_js/decode.js (@mcap/core, @foxglove/rosmsg2-serialization) decodes every message.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "regolith/record/recording.hpp"
#include "temp_dir.hpp"
#include "test_domain.hpp"

namespace fs = std::filesystem;
using regolith::record::McapReader;

namespace {

struct Result {
  int status = -1;
  std::string out;
};

/// A shell command's exit status and output (stdout and stderr).
Result shell(const std::string& cmd) {
  Result r;
  FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[65536];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

/// `regolith ARGS` through /bin/sh, after the shell commands `shell_prefix` (e.g. limits).
Result run(const std::string& args, const std::string& shell_prefix = "") {
  return shell(shell_prefix + std::string("CYCLONEDDS_URI=file://" REGOLITH_DDS_LOOPBACK_XML " ") + REGOLITH_EXE + " " +
               args);
}

#ifdef REGOLITH_NODE
/// tests/record/mcap_js/decode.js on `file`: one JSON line per channel, then per message.
Result decode_js(const fs::path& file) {
  return shell(std::string(REGOLITH_NODE) + " " REGOLITH_MCAP_JS_DIR "/decode.js " + file.string());
}
#endif

std::string read_text(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

class RunRecord : public ::testing::Test {
 protected:
  /// config/mock_rover.yaml on a domain and namespace of this process, plus `extra` at the end.
  fs::path write_config(const std::string& name, const std::string& extra, bool dds_enabled = true) {
    std::string yaml = read_text(fs::path(REGOLITH_SOURCE_DIR) / "config/mock_rover.yaml");
    const std::string from = "  enabled: true\n  domain: 0\n  namespace: rover1";
    const auto at = yaml.find(from);
    EXPECT_NE(at, std::string::npos) << "config/mock_rover.yaml's dds block changed";
    if (at != std::string::npos) {
      yaml.replace(at, from.size(),
                   std::string("  enabled: ") + (dds_enabled ? "true" : "false") +
                       "\n  domain: " + std::to_string(regolith::testing::test_domain()) + "\n  namespace: " + ns_);
    }
    yaml += extra;
    const fs::path p = dir_ / name;
    std::ofstream(p, std::ios::binary) << yaml;
    return p;
  }
  // One directory per test, kept when the test fails (the recordings are worth reading).
  const regolith::testing::TempDir tmp_{
      std::string("run_record_") + ::testing::UnitTest::GetInstance()->current_test_info()->name(),
      regolith::testing::TempDir::kKeepOnFailure};
  const fs::path& dir_ = tmp_.path();
  std::string ns_ = "rr" + std::to_string(getpid());
};

TEST_F(RunRecord, SimTimeRunRecordsEveryPublishedSample) {
  // The record: block names one file; --record overrides it.
  const fs::path cfg = write_config(
      "rover_rec.yaml", "\nrecord: {file: " + (dir_ / "from_yaml.mcap").string() + ", compression: zstd}\n");
  const fs::path out = dir_ / "drive.mcap";
  const Result r =
      run("run --sim-time --duration 6 --summary-interval 1000 --config " + cfg.string() + " --record " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  ASSERT_TRUE(fs::exists(out)) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "from_yaml.mcap"));

  // Published counts from the run's final summary: "/rr123/joint_states published 301 dropped 0 ...".
  std::map<std::string, std::uint64_t> published;
  const std::regex line(R"((/\S+) published (\d+) dropped (\d+))");
  for (std::sregex_iterator it(r.out.begin(), r.out.end(), line), end; it != end; ++it) {
    published[(*it)[1].str()] = std::stoull((*it)[2].str());
    EXPECT_EQ((*it)[3].str(), "0") << (*it)[0].str();
  }
  ASSERT_GE(published.size(), 10u) << r.out;

  McapReader reader(out);
  const auto& info = reader.info();
  EXPECT_TRUE(info.from_summary);
  EXPECT_FALSE(info.truncated);
  EXPECT_TRUE(info.problems.empty());
  EXPECT_EQ(info.profile, "ros2");
  EXPECT_EQ(info.library.rfind("regolith run ", 0), 0u) << info.library;

  // The deployment file, byte for byte.
  ASSERT_EQ(info.attachments.size(), 1u);
  EXPECT_EQ(info.attachments[0].name, "rover_rec.yaml");
  EXPECT_EQ(info.attachments[0].media_type, "application/yaml");
  const auto bytes = reader.read_attachment(info.attachments[0]);
  EXPECT_EQ(std::string(bytes.begin(), bytes.end()), read_text(cfg));

  // The run's metadata, then the HAL recording's time origin and end.
  ASSERT_EQ(info.metadata.size(), 3u);
  EXPECT_EQ(info.metadata[0].name, "regolith");
  EXPECT_EQ(info.metadata[1].name, "regolith_hal");
  EXPECT_EQ(info.metadata[1].values.at("time_origin_ns"), "1000000000");  // the simulated clock's start
  EXPECT_EQ(info.metadata[2].name, "regolith_hal_end");
  EXPECT_EQ(info.metadata[2].values.at("time_end_ns"), "7000000000");
  auto md = info.metadata[0].values;
  EXPECT_EQ(md["deployment"], "mock_rover");
  EXPECT_EQ(md["sim_time"], "true");
  EXPECT_FALSE(md["version"].empty());
  EXPECT_TRUE(std::regex_match(md["start_time"], std::regex(R"(\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{9}Z)")))
      << md["start_time"];

  std::map<std::string, std::uint64_t> recorded;
  for (const auto& [id, ch] : info.channels) {
    EXPECT_EQ(ch.message_encoding, "cdr");
    EXPECT_EQ(info.schemas.at(ch.schema_id).encoding, "ros2msg");
    recorded[ch.topic] = info.message_counts.count(id) ? info.message_counts.at(id) : 0;
  }
  const std::string n = "/" + ns_ + "/";
  for (const std::string& t :
       {n + "joint_states", n + "imu", std::string("/diagnostics"), std::string("/tf_static"), std::string("/tf"),
        n + "odom", n + "odom/wheel", n + "terrain/grid_map", n + "terrain/rocks", n + "terrain/wheel_sinkage",
        n + "terrain/soil", n + "terrain/world_map", n + "terrain/world_rocks", std::string("/clock"),
        std::string("/rosout")}) {
    EXPECT_TRUE(recorded.count(t)) << t;
  }
  // Simulated time: every published sample is in the file, exactly.
  for (const auto& [topic, count] : published) {
    ASSERT_TRUE(recorded.count(topic)) << topic;
    EXPECT_EQ(recorded[topic], count) << topic;
  }
  EXPECT_EQ(recorded[n + "joint_states"], 301u);  // 6 s at 50 Hz, cycles 0..300
  EXPECT_EQ(recorded["/tf_static"], 1u);
  EXPECT_GT(recorded["/diagnostics"], 0u);

  // The devices' inputs: every frame the components took (front at the terrain group's 2 Hz, the
  // wheel camera at 10 Hz), the encoder samples and the answers the components were given.
  EXPECT_EQ(recorded["/hal/cameras/front/image"], 13u);  // cycles at 0, 0.5, ..., 6 s
  EXPECT_EQ(recorded["/hal/cameras/wheel_cam/image"], 61u);
  EXPECT_GT(recorded["/hal/encoders/wheels/samples"], 1000u);
  EXPECT_GT(recorded["/hal/encoders/wheels/queries"], 0u);
  EXPECT_GT(recorded["/hal/imus/body_imu/samples"], 0u);
  EXPECT_EQ(recorded["/hal/imus/body_imu/samples"], recorded["/hal/imus/body_imu/attitude"]);
  EXPECT_EQ(recorded["/hal/cameras/front/image_corrupt"], 0u);
  EXPECT_NE(r.out.find(", 0 dropped"), std::string::npos) << r.out;

  // The file is on the simulated time line (ROS time = simulated time here, from 1 s to 7 s),
  // not the wall clock's: a player shows the 6 s the rover ran, however fast it ran.
  EXPECT_GE(info.message_start_time, 900'000'000u);
  EXPECT_EQ(info.message_end_time, 7'000'000'000u);

  // Per channel: log times never go back, sequences count from 0 (the DDS topics; a device's
  // messages carry its own frame / sample numbers), CDR encapsulation header. A DDS sample's log
  // time is its source time, the simulated time of the cycle that published it (joint_states:
  // every 20 ms from 1 s); a device's message is logged at its capture time (front: every 0.5 s).
  std::map<std::uint16_t, std::uint64_t> last_time;
  std::map<std::uint16_t, std::uint32_t> next_seq;
  std::uint64_t total = 0, dds_total = 0;
  const auto problems = reader.for_each_message([&](const regolith::record::MessageView& m) {
    ++total;
    EXPECT_GE(m.log_time, last_time[m.channel.id]) << m.channel.topic;
    last_time[m.channel.id] = m.log_time;
    if (m.channel.topic.rfind("/hal/", 0) != 0) {
      ++dds_total;
      EXPECT_EQ(m.sequence, next_seq[m.channel.id]++) << m.channel.topic;
      EXPECT_EQ(m.log_time, m.publish_time) << m.channel.topic;
    }
    if (m.channel.topic == n + "joint_states") {
      EXPECT_EQ(m.log_time, 1'000'000'000u + 20'000'000ull * m.sequence) << "joint_states #" << m.sequence;
    }
    if (m.channel.topic == "/hal/cameras/front/image") {
      EXPECT_EQ(m.log_time, 1'000'000'000u + 500'000'000ull * m.sequence) << "front frame #" << m.sequence;
    }
    ASSERT_GE(m.data.size(), 4u);
    EXPECT_EQ(m.data[0], 0x00);
    EXPECT_EQ(m.data[1], 0x01);
  });
  EXPECT_TRUE(problems.empty());
  EXPECT_EQ(total, info.message_count);
  EXPECT_NE(r.out.find("recorded " + std::to_string(dds_total) + " samples"), std::string::npos) << r.out;

#ifdef REGOLITH_NODE
  // An independent reader and decoder (@mcap/core + @foxglove/rosmsg2-serialization) decodes every
  // message of the file.
  {
    const Result d = decode_js(out);
    const std::string& js = d.out;
    EXPECT_EQ(d.status, 0) << js.substr(0, 2000);
    std::uint64_t decoded = 0;
    for (std::size_t at = js.find("{\"topic\":"); at != std::string::npos; at = js.find("{\"topic\":", at + 1))
      ++decoded;
    EXPECT_EQ(decoded, total);
  }
#endif

  const Result li = run("log info " + out.string());
  EXPECT_EQ(li.status, 0) << li.out;
  EXPECT_NE(li.out.find("attachment:  rover_rec.yaml (application/yaml"), std::string::npos) << li.out;
  EXPECT_NE(li.out.find("metadata:    regolith: "), std::string::npos) << li.out;
  EXPECT_NE(li.out.find(n + "joint_states"), std::string::npos) << li.out;
}

TEST_F(RunRecord, RawCanFramesAreRecordedAndExportAsACandumpLog) {
  // A candump log of 100 Hz wheel frames with an error frame and a CAN FD frame in between,
  // replayed by the `candump` encoder backend: every frame of the first 0.5 s is recorded as
  // can_msgs/Frame (or FdFrame), and `log export` gives the same lines back (times shifted to the
  // simulated clock, interface = the encoder set's id).
  std::string log;
  std::vector<std::string> bodies;  // "ID#DATA" of each frame due by 0.5 s
  for (int i = 0; i < 80; ++i) {
    char line[96], body[64];
    const unsigned v = (60000u + 100u * static_cast<unsigned>(i)) & 0xFFFFu;
    std::snprintf(body, sizeof body, "0CF#%02X%02X", v & 0xFF, v >> 8);
    std::snprintf(line, sizeof line, "(1700000000.%06d) can0 %s\n", i * 10000, body);
    log += line;
    if (i <= 50) bodies.push_back(body);
    if (i == 7 || i == 23) {
      const char* extra = i == 7 ? "20000004#0000080000000000" : "1A0##0112233445566778899AABB";
      std::snprintf(line, sizeof line, "(1700000000.%06d) can0 %s\n", i * 10000 + 3000, extra);
      log += line;
      bodies.push_back(i == 7 ? extra : "1A0##0112233445566778899AABB");
    }
  }
  std::ofstream(dir_ / "bus.log") << log;
  const fs::path cfg = dir_ / "can.yaml";
  std::ofstream(cfg)
      << "name: can_rec\n"
         "dds: {enabled: true, domain: "
      << regolith::testing::test_domain() << ", namespace: " << ns_
      << "}\n"
         "rover:\n  wheels:\n    - {name: fl, x_m: 0.0, y_m: 0.2, radius_m: 0.1, width_m: 0.05, encoders: bus}\n"
         "devices:\n  encoders:\n    bus:\n      backend: candump\n      file: bus.log\n      interface: can0\n"
         "      wheels:\n        fl: {id: 0x0CF, length: 2, signed: false, scale: 0.001}\n"
         "rate_groups:\n  - {name: io, rate_hz: 100, members: [joint_states]}\n"
         "components:\n  joint_states: {type: joint_state_publisher, encoders: bus}\n";
  const fs::path out = dir_ / "can.mcap";
  const Result r = run("run --sim-time --duration 0.5 --quiet --config " + cfg.string() + " --record " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  McapReader reader(out);
  std::map<std::string, std::uint64_t> recorded;
  for (const auto& [id, ch] : reader.info().channels)
    recorded[ch.topic] = reader.info().message_counts.count(id) ? reader.info().message_counts.at(id) : 0;
  EXPECT_EQ(recorded["/hal/encoders/bus/can"], bodies.size() - 1);  // 51 wheel frames + the error frame
  EXPECT_EQ(recorded["/hal/encoders/bus/can_fd"], 1u);
  EXPECT_EQ(recorded["/hal/encoders/bus/samples"], 51u);  // every decoded sample, up to the end of the run

  const Result ex = run("log export " + out.string() + " --topic /hal/encoders/bus/can --topic can_fd --out " +
                        (dir_ / "export").string());
  ASSERT_EQ(ex.status, 0) << ex.out;
  std::vector<std::string> lines;
  for (const char* f : {"hal_encoders_bus_can.log", "hal_encoders_bus_can_fd.log"}) {
    std::istringstream in(read_text(dir_ / "export" / f));
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  ASSERT_EQ(lines.size(), bodies.size());
  // Sorted by time: the FD frame's line is in the second file.
  std::sort(lines.begin(), lines.end());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const std::string t = lines[i].substr(1, lines[i].find(')') - 1);
    const std::string body = lines[i].substr(lines[i].rfind(' ') + 1);
    EXPECT_EQ(lines[i].substr(lines[i].find(')') + 2, 4), "bus ") << lines[i];
    EXPECT_EQ(body, bodies[i]) << lines[i];
  }
  EXPECT_EQ(lines.front().substr(0, 10), "(1.000000)") << "the simulated clock starts at 1 s";
#ifdef REGOLITH_NODE
  // The independent decoder (Foxglove's, from the official .msg text) reads the frames field for field.
  const Result d = decode_js(out);
  const std::string& js = d.out;
  ASSERT_EQ(d.status, 0) << js.substr(0, 2000);
  EXPECT_NE(js.find("\"id\":416,\"is_extended\":false,\"is_error\":false,\"len\":11,\"data\":[17,34,51,68,85,102,119,"
                    "136,153,170,187]"),
            std::string::npos)
      << js.substr(0, 3000);
  EXPECT_NE(
      js.find("\"id\":4,\"is_rtr\":false,\"is_extended\":true,\"is_error\":true,\"dlc\":8,\"data\":[0,0,8,0,0,0,0,0]"),
      std::string::npos)
      << js.substr(0, 3000);
#endif
}

TEST_F(RunRecord, RecordBlockFromYamlWithTopicSubset) {
  const fs::path out = dir_ / "subset.mcap";
  const fs::path cfg =
      write_config("subset.yaml", "\nrecord:\n  file: " + out.string() +
                                      "\n  topics: [joint_states, /diagnostics]\n  compression: none\n");
  const Result r = run("run --sim-time --duration 2 --quiet --config " + cfg.string());
  ASSERT_EQ(r.status, 0) << r.out;
  McapReader reader(out);
  // The two topics and the devices' inputs (three cameras with a corrupt-frame channel each, two
  // encoder sets with samples and queries, the IMU's samples, attitudes and queries).
  ASSERT_EQ(reader.info().channels.size(), 2u + 6u + 4u + 3u);
  std::map<std::string, std::uint64_t> recorded;
  for (const auto& [id, ch] : reader.info().channels)
    recorded[ch.topic] = reader.info().message_counts.count(id) ? reader.info().message_counts.at(id) : 0;
  EXPECT_EQ(recorded["/" + ns_ + "/joint_states"], 101u);  // 2 s at 50 Hz
  EXPECT_GT(recorded["/diagnostics"], 0u);
  for (const auto& c : reader.info().chunks) EXPECT_EQ(c.compression, "");
}

TEST_F(RunRecord, RecordBlockSplitsTheRecordingBySize) {
  const fs::path out = dir_ / "split.mcap";
  const fs::path cfg = write_config("split.yaml", "\nrecord:\n  file: " + out.string() +
                                                      "\n  topics: [joint_states]\n  hal: false\n  split_mb: 0.01\n");
  const Result r = run("run --sim-time --duration 3.5 --quiet --config " + cfg.string());
  ASSERT_EQ(r.status, 0) << r.out;
  const std::size_t at = r.out.find("split into ");
  ASSERT_NE(at, std::string::npos) << r.out;
  const int files = std::atoi(r.out.c_str() + at + 11);
  ASSERT_GE(files, 2) << r.out;  // ~22 kB of joint states in files of ~10 KiB
  EXPECT_NE(r.out.find(" files: split.mcap split_001.mcap"), std::string::npos) << r.out;
  std::uint64_t joint_states = 0;
  for (int k = 0; k < files; ++k) {
    const fs::path f = regolith::record::mcap_split_path(out, static_cast<std::size_t>(k));
    McapReader reader(f);
    EXPECT_TRUE(reader.info().from_summary) << f;
    EXPECT_FALSE(reader.info().attachments.empty()) << f << ": the deployment in every file";
    for (const auto& [id, ch] : reader.info().channels)
      if (ch.topic == "/" + ns_ + "/joint_states")
        joint_states += reader.info().message_counts.count(id) ? reader.info().message_counts.at(id) : 0;
  }
  EXPECT_FALSE(fs::exists(regolith::record::mcap_split_path(out, static_cast<std::size_t>(files))));
  EXPECT_EQ(joint_states, 176u);  // 3.5 s at 50 Hz, both ends included: none lost or doubled
}

TEST_F(RunRecord, ConfigCheckTakesSeveralDeployments) {
  // `regolith config check config/*.yaml`: one line per deployment, every error with its file, the
  // files after a bad one still checked, exit 2 when any has an error.
  const fs::path good = write_config("good.yaml", "");
  const fs::path typo = write_config("typo.yaml", "\nrecord: {fille: x.mcap}\n");
  const fs::path bench = fs::path(REGOLITH_SOURCE_DIR) / "config/wheel_leg_bench.yaml";
  Result r = run("config check " + good.string() + " " + typo.string() + " " + bench.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("# " + good.string() + ": OK ("), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("# " + bench.string() + ": OK ("), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("typo.yaml"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.fille"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("config check: 1 of 3 deployments have errors"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("process.lock_memory"), std::string::npos) << r.out;  // no resolved listing
  // A file that is not there is one of the errors, named.
  r = run("config check " + good.string() + " " + (dir_ / "missing.yaml").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("missing.yaml"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 of 2 deployments have errors"), std::string::npos) << r.out;
  // All good: exit 0; --dot takes one deployment.
  r = run("config check " + good.string() + " " + bench.string());
  EXPECT_EQ(r.status, 0) << r.out;
  r = run("config check --dot " + good.string() + " " + bench.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--dot takes one deployment (2 given)"), std::string::npos) << r.out;
}

TEST_F(RunRecord, ConfigErrors) {
  // record: with DDS disabled: a located error naming record.file.
  const fs::path no_dds = write_config("no_dds.yaml", "\nrecord: {file: x.mcap}\n", /*dds_enabled=*/false);
  Result r = run("run --sim-time --duration 1 --quiet --config " + no_dds.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no_dds.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.file: recording needs DDS"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "x.mcap"));
  // --record with DDS disabled names the option.
  const fs::path plain_no_dds = write_config("plain_no_dds.yaml", "", /*dds_enabled=*/false);
  r = run("run --sim-time --duration 1 --quiet --config " + plain_no_dds.string() + " --record " +
          (dir_ / "y.mcap").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--record: recording needs DDS"), std::string::npos) << r.out;
  // An unknown key is a located error with a suggestion; an unknown topic names record.topics.
  const fs::path typo = write_config("typo.yaml", "\nrecord: {fille: x.mcap}\n");
  r = run("config check " + typo.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("record.fille"), std::string::npos) << r.out;
  const fs::path bad_topic =
      write_config("bad_topic.yaml", "\nrecord: {file: " + (dir_ / "z.mcap").string() + ", topics: [joint_state]}\n");
  r = run("run --sim-time --duration 1 --quiet --config " + bad_topic.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("record.topics: unknown topic 'joint_state'"), std::string::npos) << r.out;
  // ... said before the deployment is built (no rendering, no device opened), and by `config check`.
  EXPECT_EQ(r.out.find("rate groups"), std::string::npos) << r.out;
  r = run("config check " + bad_topic.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("bad_topic.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.topics: unknown topic 'joint_state'"), std::string::npos) << r.out;
  // a split size below 0.01 MiB names record.split_mb
  const fs::path tiny = write_config("tiny_split.yaml", "\nrecord: {file: x.mcap, split_mb: 0.001}\n");
  r = run("config check " + tiny.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("record.split_mb: must be 0 (never) or >= 0.01 MiB"), std::string::npos) << r.out;
  // config check lists the blocks with their defaults.
  r = run("config check " + write_config("ok.yaml", "").string());
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("record.file"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.compression"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.hal"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.split_mb"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("record.split_s"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("live.listen"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("127.0.0.1:8765"), std::string::npos) << r.out;
#ifndef REGOLITH_NO_LIVE
  // live: a port out of range is located at live.listen; the block serves on an ephemeral port.
  const fs::path bad_live = write_config("bad_live.yaml", "\nlive: {enabled: true, listen: '127.0.0.1:99999'}\n");
  r = run("run --sim-time --duration 1 --quiet --config " + bad_live.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("bad_live.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("live.listen: "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("rate groups"), std::string::npos) << r.out;  // before the deployment is built
  r = run("config check " + bad_live.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("bad_live.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("live.listen: expected [ADDR:]PORT"), std::string::npos) << r.out;
  r = run("run --sim-time --duration 1 --quiet --config " + plain_no_dds.string() + " --live 0");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--live: needs DDS, but the deployment has dds.enabled: false"), std::string::npos) << r.out;
  const fs::path ok_live =
      write_config("ok_live.yaml", "\nlive: {enabled: true, listen: '127.0.0.1:0', max_clients: 2}\n");
  r = run("run --sim-time --duration 1 --quiet --config " + ok_live.string());
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(std::regex_search(
      r.out, std::regex(R"(live: Foxglove WebSocket server on ws://127\.0\.0\.1:[1-9]\d*, page http://)")))
      << r.out;
  // Every interface needs a token: without one the error is located at live.listen (config) or
  // names --live (command line); a token file others can read is located at live.token_file.
  const fs::path open_live = write_config("open_live.yaml", "\nlive: {enabled: true, listen: '0.0.0.0:0'}\n");
  r = run("run --sim-time --duration 1 --quiet --config " + open_live.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("open_live.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("live.listen: listening on 0.0.0.0 (not a loopback address) needs an access token"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("rate groups"), std::string::npos) << r.out;
  r = run("run --sim-time --duration 1 --quiet --config " + ok_live.string() + " --live 0.0.0.0:0");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--live: listening on 0.0.0.0"), std::string::npos) << r.out;
  {
    std::ofstream(dir_ / "live.token") << "abc123\n";
    fs::permissions(dir_ / "live.token", fs::perms::owner_read | fs::perms::owner_write | fs::perms::others_read,
                    fs::perm_options::replace);
  }
  const fs::path leaky =
      write_config("leaky.yaml", "\nlive: {enabled: true, listen: '0.0.0.0:0', token_file: live.token}\n");
  r = run("run --sim-time --duration 1 --quiet --config " + leaky.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("leaky.yaml:"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("live.token_file: token file '" + (dir_ / "live.token").string() + "': mode 0604"),
            std::string::npos)
      << r.out;
  EXPECT_EQ(r.out.find("rate groups"), std::string::npos) << r.out;
  fs::permissions(dir_ / "live.token", fs::perms::owner_read | fs::perms::owner_write, fs::perm_options::replace);
  r = run("run --sim-time --duration 1 --quiet --config " + leaky.string());
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(live: Foxglove WebSocket server on ws://0\.0\.0\.0:[1-9]\d*)")))
      << r.out;
#endif
}

TEST_F(RunRecord, AFullDiskStopsTheRecordingNotTheRover) {
  const fs::path cfg = write_config("rover.yaml", "");
  // The file may not grow past 300 KiB (EFBIG, as a full disk's ENOSPC): the recording stops
  // with one error naming the file, the rover runs its 20 s to the end (every device keeps
  // delivering), the summary is printed, and the command fails at the end, saying what was lost.
  const fs::path file = dir_ / "full.mcap";
  Result r = run("run --sim-time --duration 20 --quiet --config " + cfg.string() + " --record " + file.string(),
                 "trap '' XFSZ; ulimit -f 300; ");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("record: " + file.string() + ": write failed at byte "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("recording stopped; the deployment keeps running"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("run: the recording stopped early: " + file.string()), std::string::npos) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(R"(; [1-9]\d* later samples not recorded)"))) << r.out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex(R"(recorded device encoders wheels +(\d+) messages)"))) << r.out;
  EXPECT_GT(std::stol(m[1]), 15000) << "the rover stopped early: " << r.out;  // 20 s of wheel samples
  EXPECT_LE(fs::file_size(file), 300u * 1024u);
  // A file that cannot take even its header: refused before anything starts, named.
  r = run("run --sim-time --duration 1 --quiet --config " + cfg.string() + " --record /dev/full");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("run: --record: /dev/full: write failed"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("No space left on device"), std::string::npos) << r.out;
}

TEST_F(RunRecord, ReplayPublishesTheRecordedRunBitForBit) {
  const fs::path cfg = write_config("rover.yaml", "");
  const fs::path a = dir_ / "a.mcap", b = dir_ / "b.mcap";
  Result r = run("run --sim-time --duration 3 --quiet --config " + cfg.string() + " --record " + a.string());
  ASSERT_EQ(r.status, 0) << r.out;
  // A device as the deployment to replay with is refused, not read forever.
  r = run("replay " + a.string() + " --quiet --config /dev/zero");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("replay: --config: /dev/zero: not a regular file"), std::string::npos) << r.out;
  // The recorded deployment with replay devices, as long as the recording, on simulated time;
  // every published sample of every topic equal byte for byte (stamps included).
  r = run("replay " + a.string() + " --quiet --record " + b.string() + " --compare");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("replay identical to the recording"), std::string::npos) << r.out;
  const std::string n = "/" + ns_ + "/";
  for (const std::string& t : {n + "terrain/grid_map", n + "terrain/rocks", n + "terrain/wheel_sinkage",
                               n + "terrain/soil", n + "odom", n + "imu", std::string("/tf")}) {
    const std::regex row(t + R"(\s+(\d+)\s+(\d+)\s+(\d+)\s+-)");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(r.out, m, row)) << t << "\n" << r.out;
    EXPECT_GT(std::stoi(m[1].str()), 0) << t;
    EXPECT_EQ(m[1].str(), m[3].str()) << t;
  }
  // The replay's own recording holds the devices again: it replays the same way.
  McapReader rb(b);
  bool has_hal = false;
  for (const auto& [id, ch] : rb.info().channels) has_hal = has_hal || ch.topic == "/hal/cameras/front/image";
  EXPECT_TRUE(has_hal);

  // `assess` reads one recorded frame, with the recorded deployment's camera and sun.
  r = run("assess " + a.string() + " --device front --frame 1 --out " + (dir_ / "assess").string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("camera front, frame 1 of "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("light given slant 35."), std::string::npos) << "the recorded deployment's sun\n" << r.out;
  EXPECT_TRUE(fs::exists(dir_ / "assess" / "summary.json"));
  EXPECT_TRUE(fs::exists(dir_ / "assess" / "range.tiff"));
  r = run("assess " + a.string() + " --frame 1 --out " + (dir_ / "assess2").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("3 cameras recorded (wheel_cam, front, rear): choose one with --device"), std::string::npos)
      << r.out;
  r = run("assess " + a.string() + " --device front --frame 999 --out " + (dir_ / "assess2").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("/hal/cameras/front/image has "), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame 999 is past the end"), std::string::npos) << r.out;

  // The recording replayed by an edited deployment (written to STEM.yaml, recorded to STEM.mcap).
  const auto replay_edited = [&](const std::string& yaml, const std::string& stem) {
    const fs::path edited = dir_ / (stem + ".yaml");
    std::ofstream(edited) << yaml;
    return run("replay " + a.string() + " --quiet --config " + edited.string() + " --record " +
               (dir_ / (stem + ".mcap")).string() + " --compare");
  };
  // Another deployment on the same inputs (a different rock threshold): the rocks differ and the
  // comparison says where, with exit status 1.
  std::string yaml = read_text(cfg);
  const auto at = yaml.find("threshold_scale: 2.0");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 20, "threshold_scale: 0.5");
  r = replay_edited(yaml, "changed");
  EXPECT_EQ(r.status, 1) << r.out;
  EXPECT_NE(r.out.find("replay differs from the recording"), std::string::npos) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex(n + R"(terrain/rocks\s+\d+\s+\d+\s+\d+\s+sample \d+)"))) << r.out;

  // Other preview settings only (JPEG quality): the previews differ, but they are best effort (a
  // worker thread outside the rate groups draws them), so the replay still compares as identical.
  yaml = read_text(cfg);
  const auto src = yaml.find("    source: rocks\n");
  ASSERT_NE(src, std::string::npos);
  yaml.insert(src + std::string("    source: rocks\n").size(), "    jpeg_quality: 40\n");
  r = replay_edited(yaml, "quality");
  EXPECT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("replay identical to the recording"), std::string::npos) << r.out;
  EXPECT_TRUE(std::regex_search(
      r.out, std::regex(n + R"(preview/rocks/compressed\s+\d+\s+\d+\s+\d+\s+\S+ \d* ?\(best effort: not counted\))")))
      << r.out;
}

TEST_F(RunRecord, MapReadsARecordingWithItsWheelOdometry) {
  // `regolith map REC.mcap`: the front camera's frames, the skid-steer odometry of the recorded
  // encoder samples (rover.wheels of the recorded deployment) with the heading of its IMU
  // (rover.imu, as the terrain_map component takes it), and its sun. The mocked rover drives
  // 0.1 m/s on a left arc of radius 8 m with 5 % wheel slip on both sides: over the 6 s of frames
  // the wheels roll 0.63 m (they alone would turn the body by 0.63 / 8 = 0.079 rad), the body
  // turns by 0.6 / 8 = 0.075 rad, which the IMU reports.
  const fs::path cfg = write_config("map.yaml", "");
  const fs::path rec = dir_ / "drive.mcap", out = dir_ / "map";
  Result r = run("run --sim-time --duration 6 --quiet --config " + cfg.string() + " --record " + rec.string());
  ASSERT_EQ(r.status, 0) << r.out;
  r = run("map " + rec.string() + " --out " + out.string() + " -q");
  ASSERT_EQ(r.status, 0) << r.out;
  const std::regex head(
      R"(camera front, (\d+) frames, encoder set wheels \(6 wheels, (\d+) samples\), heading imu body_imu \((\d+) samples\), wheel path ([0-9.]+) m)");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, head)) << r.out;
  EXPECT_EQ(std::stoi(m[1].str()), 13) << "2 Hz for 6 s, both ends";
  EXPECT_GE(std::stoi(m[2].str()), 6 * 600 - 6) << "100 Hz per wheel";
  EXPECT_GE(std::stoi(m[3].str()), 6 * 100 - 6) << "the IMU's 100 Hz";
  EXPECT_NEAR(std::stod(m[4].str()), 0.63, 0.02);
  for (const char* f : {"map.json", "elevation.tiff", "hazard.tiff", "rocks.csv", "odometry.csv", "frames.csv",
                        "frames/00000.png", "frames/00012.png"})
    EXPECT_TRUE(fs::exists(out / f)) << f;
  // The frames, frames.csv and input.json written beside the map are a drive directory: mapped
  // again from there, the same 13 frames.
  const fs::path again = dir_ / "map_again";
  r = run("map " + out.string() + " --out " + again.string() + " -q");
  ASSERT_EQ(r.status, 0) << r.out;
  std::ifstream odo(again / "odometry.csv");
  int rows = -1;
  for (std::string l; std::getline(odo, l);) rows += !l.empty();
  EXPECT_EQ(rows, 13) << "poses of the drive directory written from the recording";
  // The last frame's odometry pose: the IMU's heading (the true one), the wheels' 0.63 m along an
  // arc of that turn (radius 0.63 / 0.075 = 8.4 m).
  std::ifstream csv(out / "frames.csv");
  std::string line, last;
  while (std::getline(csv, line)) last = line;
  double x = 0, y = 0, yaw = 0;
  ASSERT_EQ(std::sscanf(last.c_str(), "%*d,%*[^,],%*f,%lf,%lf,%lf", &x, &y, &yaw), 3) << last;
  EXPECT_NEAR(yaw, 0.6 / 8, 0.0005) << "the IMU's heading, not the slipping wheels' 0.079 rad";
  EXPECT_NEAR(x, 8.4 * std::sin(0.075), 0.005);
  EXPECT_NEAR(y, 8.4 * (1 - std::cos(0.075)), 0.002);
  // Errors name the file and what is missing.
  r = run("map " + rec.string() + " --device nope --out " + (dir_ / "map2").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no rover.cameras.nope in the recorded deployment"), std::string::npos) << r.out;
  r = run("map " + rec.string() + " --encoders wheel_leg --out " + (dir_ / "map3").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no rover.wheels entry reports to encoder set 'wheel_leg'"), std::string::npos) << r.out;
}

TEST_F(RunRecord, MapTakesTheFramesOfARecordingTheLiveComponentTook) {
  // The front camera's clock steps back 1.2 s at frame 4 (stamped 0.8 s, after frame 3's 1.5 s):
  // the live terrain_map skips it (mapping::FrameOrder) and so does `regolith map REC.mcap`, which
  // keeps the recorded order instead of sorting the frames by stamp.
  std::string yaml = read_text(write_config("step.yaml", ""));
  const std::string front = "    front: &drive ";
  const auto at = yaml.find(front);
  ASSERT_NE(at, std::string::npos) << "config/mock_rover.yaml's front camera changed";
  const auto line_end = yaml.find('\n', at);
  const auto rear = yaml.find("    rear:", at);
  std::string drive = yaml.substr(line_end + 1, rear - line_end - 1), indented;
  for (std::size_t b = 0; b < drive.size();) {
    const auto e = drive.find('\n', b);
    indented += "  " + drive.substr(b, e - b + 1);
    b = e + 1;
  }
  yaml = yaml.substr(0, at) +
         "    front:\n      backend: fault_injection\n      stamp_step_after: 4\n      stamp_step_for: 1\n"
         "      stamp_step_ms: -1200\n      inner: &drive\n" +
         indented + yaml.substr(rear);
  const fs::path cfg = dir_ / "step.yaml", rec = dir_ / "step.mcap", out = dir_ / "map";
  std::ofstream(cfg, std::ios::binary) << yaml;
  Result r = run("run --sim-time --duration 6 --config " + cfg.string() + " --record " + rec.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("map 12 frames"), std::string::npos) << "13 frames, one skipped\n" << r.out;
  EXPECT_NE(r.out.find("camera clock stepped back"), std::string::npos) << r.out;
  r = run("map " + rec.string() + " --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("camera front, 12 frames"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("1 frames stamped at or before the frame mapped before them"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out / "frames/00004.png")) << "the skipped frame is not part of the drive";
  EXPECT_TRUE(fs::exists(out / "frames/00005.png"));
}

TEST_F(RunRecord, ReplayPlaysEveryFileOfASplitRecording) {
  // 3 s of the mocked rover in files of 8 MiB (~23 MiB of frames: 3 files). `replay` of the first
  // file plays the whole recording: every output sample of every file again, byte for byte.
  const fs::path cfg = write_config("rover.yaml", "\nrecord:\n  split_mb: 8\n");
  const fs::path a = dir_ / "a.mcap", b = dir_ / "b.mcap";
  Result r = run("run --sim-time --duration 3 --quiet --config " + cfg.string() + " --record " + a.string());
  ASSERT_EQ(r.status, 0) << r.out;
  const std::vector<fs::path> files = regolith::record::mcap_split_files(a);
  ASSERT_GE(files.size(), 2u) << r.out;
  std::uint64_t recorded_rocks = 0;
  for (const fs::path& f : files) {
    McapReader reader(f);
    for (const auto& [id, ch] : reader.info().channels)
      if (ch.topic == "/" + ns_ + "/terrain/rocks")
        recorded_rocks += reader.info().message_counts.count(id) ? reader.info().message_counts.at(id) : 0;
  }
  r = run("replay " + a.string() + " --quiet --record " + b.string() + " --compare");
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("replay identical to the recording"), std::string::npos) << r.out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(r.out, m, std::regex("/" + ns_ + R"(/terrain/rocks\s+(\d+)\s+(\d+)\s+(\d+)\s+-)")))
      << r.out;
  EXPECT_EQ(std::stoull(m[1].str()), recorded_rocks) << "the comparison reads every file of the recording";
  EXPECT_EQ(m[1].str(), m[3].str());
  // A stray sibling from another recording (another time origin) is not part of it.
  const fs::path c = dir_ / "c.mcap";
  r = run("run --sim-time --duration 1 --quiet --config " + write_config("small.yaml", "").string() + " --record " +
          c.string());
  ASSERT_EQ(r.status, 0) << r.out;
  fs::copy_file(b, regolith::record::mcap_split_path(c, 1));
  r = run("replay " + c.string() + " --quiet --record " + (dir_ / "d.mcap").string() + " --compare");
  EXPECT_NE(r.out.find("is not part of the recording"), std::string::npos) << r.out;
  EXPECT_EQ(r.status, 0) << r.out;
}

// A recording cut off before its end record (power loss: the file stops mid-chunk) replays its
// readable part without --duration: as long as its last readable device sample.
TEST_F(RunRecord, ACutRecordingReplaysItsReadablePart) {
  const fs::path cfg = write_config("cut.yaml", "");
  const fs::path a = dir_ / "whole.mcap", cut = dir_ / "cut.mcap";
  Result r = run("run --sim-time --duration 3 --quiet --config " + cfg.string() + " --record " + a.string());
  ASSERT_EQ(r.status, 0) << r.out;
  {
    std::ifstream in(a, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    ASSERT_GT(bytes.size(), 100000u);
    std::ofstream(cut, std::ios::binary) << bytes.substr(0, bytes.size() / 2);
  }
  {
    McapReader reader(cut);
    const regolith::TimeNs last = regolith::record::last_hal_stamp(reader);
    EXPECT_GT(last, regolith::kNsPerSec) << "after the simulated clock's start (1 s)";
    EXPECT_LT(last, 4 * regolith::kNsPerSec) << "before the whole recording's end (4 s)";
  }
  r = run("replay " + cut.string() + " --quiet");
  ASSERT_EQ(r.status, 0) << r.out;
  std::smatch m;
  ASSERT_TRUE(std::regex_search(
      r.out, m,
      std::regex(R"(no end record \(the recording was cut short\): replaying its readable part, ([0-9.]+) s)")))
      << r.out;
  const double played = std::stod(m[1].str());
  EXPECT_GT(played, 0.2);
  EXPECT_LT(played, 3.0);
}

TEST_F(RunRecord, ReplayErrorsNameTheFile) {
  // A recording without the devices' inputs (record.hal: false): the replay devices say so.
  const fs::path a = dir_ / "no_hal.mcap";
  const fs::path cfg = write_config("no_hal.yaml", "\nrecord: {hal: false}\n");
  Result r = run("run --sim-time --duration 1 --quiet --config " + cfg.string() + " --record " + a.string());
  ASSERT_EQ(r.status, 0) << r.out;
  {
    McapReader no_hal(a);
    for (const auto& [id, ch] : no_hal.info().channels) EXPECT_NE(ch.topic.rfind("/hal/", 0), 0u) << ch.topic;
  }
  r = run("replay " + a.string() + " --quiet --duration 1");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find(a.string() + ": no HAL recording in this file"), std::string::npos) << r.out;
  r = run("assess " + a.string() + " --out " + (dir_ / "assess").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find(a.string() + ": no camera frames recorded"), std::string::npos) << r.out;
  // --compare without --record; a missing file; a file that is not MCAP.
  r = run("replay " + a.string() + " --compare");
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("--compare needs --record"), std::string::npos) << r.out;
  r = run("replay " + (dir_ / "missing.mcap").string());
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("missing.mcap"), std::string::npos) << r.out;
  std::ofstream(dir_ / "text.mcap") << "not a recording";
  r = run("replay " + (dir_ / "text.mcap").string());
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.out.find("text.mcap"), std::string::npos) << r.out;
  // The recording being replayed is never the replay's output.
  r = run("replay " + a.string() + " --record " + a.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("is the recording being replayed"), std::string::npos) << r.out;
}

}  // namespace
