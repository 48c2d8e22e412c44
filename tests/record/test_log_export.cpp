// `regolith log export` (label integration, host only): JointState and RockArray samples are
// written through Cyclone DDS in this process (same-process reader, serialized bytes taken with
// dds::take_serialized = what `regolith record` stores), put into an MCAP file with McapWriter,
// exported by the `regolith` binary, and the JSON lines / CSV rows compared field by field with
// what was written. Also: topic name spellings, unknown topic (exit 2), a file cut mid-chunk, the
// HAL recording's camera frames (PNG files) and attitudes.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "regolith/dds/sample.hpp"
#include "regolith/dds/serialized.hpp"
#include "regolith/dds/types.hpp"
#include "regolith/record/hal_messages.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "temp_dir.hpp"

namespace {

namespace fs = std::filesystem;
namespace rd = regolith::dds;
namespace m = regolith::msgs;
using nlohmann::json;

constexpr int kJointStates = 30;
constexpr int kRockArrays = 2;

struct ExportRun {
  int status = -1;
  std::string out;
};

ExportRun run(const std::string& args) {
  ExportRun r;
  FILE* p = ::popen((std::string(REGOLITH_EXE) + " log export " + args + " 2>&1").c_str(), "r");
  if (p == nullptr) return r;
  char buf[4096];
  std::size_t n = 0;
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) r.out.append(buf, n);
  const int st = ::pclose(p);
  r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  return r;
}

std::vector<std::string> lines(const fs::path& p) {
  std::ifstream in(p);
  std::vector<std::string> v;
  for (std::string l; std::getline(in, l);) v.push_back(l);
  return v;
}

/// Writes samples of one type through Cyclone and hands back their serialized bytes.
template <class Msg>
std::vector<std::vector<std::uint8_t>> serialize(dds_entity_t pp, const std::string& topic_name,
                                                 const std::vector<Msg*>& samples) {
  const dds_entity_t topic =
      dds_create_topic(pp, rd::MsgTraits<Msg>::descriptor(), topic_name.c_str(), nullptr, nullptr);
  EXPECT_GT(topic, 0);
  dds_qos_t* q = dds_create_qos();
  dds_qset_reliability(q, DDS_RELIABILITY_RELIABLE, DDS_SECS(1));
  dds_qset_history(q, DDS_HISTORY_KEEP_ALL, 0);
  const dds_entity_t reader = dds_create_reader(pp, topic, q, nullptr);
  const dds_entity_t writer = dds_create_writer(pp, topic, q, nullptr);
  dds_delete_qos(q);
  for (Msg* s : samples) EXPECT_EQ(dds_write(writer, s), DDS_RETCODE_OK);
  std::vector<std::vector<std::uint8_t>> out;
  std::vector<std::uint8_t> scratch;
  rd::take_serialized(
      reader, [&](std::span<const std::uint8_t> b, const dds_sample_info_t&) { out.emplace_back(b.begin(), b.end()); },
      scratch, 1000);
  dds_delete(writer);
  dds_delete(reader);
  dds_delete(topic);
  return out;
}

class LogExport : public ::testing::Test {
 protected:
  void SetUp() override {
    file_ = dir_ / "drive.mcap";
    const dds_entity_t pp = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
    ASSERT_GT(pp, 0);

    std::vector<m::sensor_msgs::JointState*> js;
    for (int i = 0; i < kJointStates; ++i) {
      auto* s = static_cast<m::sensor_msgs::JointState*>(dds_alloc(sizeof(m::sensor_msgs::JointState)));
      rd::reserve(*s, {.joints = 3});
      rd::set_time(s->header.stamp, 5 * regolith::kNsPerSec + i * 20 * regolith::kNsPerMs);
      // One frame_id that is not UTF-8 (another process may publish anything): exported with
      // U+FFFD in place of the bad bytes; json would otherwise throw and end the export.
      rd::copy_string(s->header.frame_id, 32, i == 7 ? "base\xff_link" : "base_link");
      rd::set_length(s->name, 3);
      rd::set_length(s->position, 3);
      rd::set_length(s->velocity, 3);
      for (std::uint32_t j = 0; j < 3; ++j) {
        rd::copy_string(s->name._buffer[j], 32, ("wheel_" + std::to_string(j)).c_str());
        s->position._buffer[j] = 0.25 * i + j;
        s->velocity._buffer[j] = j == 2 ? std::nan("") : -1.5 * j;
      }
      js.push_back(s);
    }
    std::vector<m::regolith_msgs::RockArray*> rocks;
    for (int i = 0; i < kRockArrays; ++i) {
      auto* r = static_cast<m::regolith_msgs::RockArray*>(dds_alloc(sizeof(m::regolith_msgs::RockArray)));
      rd::reserve(*r, {.rocks = 2, .hypotheses = 1});
      rd::set_time(r->header.stamp, (i + 1) * regolith::kNsPerMs);
      rd::copy_string(r->header.frame_id, 32, "front_optical_frame");
      rd::set_length(r->detections, 2);
      rd::set_length(r->ground_range_m, 2);
      rd::set_length(r->lateral_offset_m, 2);
      rd::set_length(r->width_m, 2);
      rd::set_length(r->height_m, 2);
      rd::set_length(r->hazard, 2);
      for (std::uint32_t k = 0; k < 2; ++k) {
        auto& d = r->detections._buffer[k];
        rd::set_length(d.results, 1);
        rd::copy_string(d.results._buffer[0].hypothesis.class_id, 32, "rock");
        d.results._buffer[0].hypothesis.score = 0.5 + 0.25 * k;
        d.bbox.center.position.x = 100.0 * i + k;
        d.bbox.size_x = 10.0 + k;
        rd::copy_string(d.id, 32, ("r" + std::to_string(i) + "_" + std::to_string(k)).c_str());
        r->ground_range_m._buffer[k] = 1.5 + i + k;
        r->lateral_offset_m._buffer[k] = -0.25 * k;
        r->width_m._buffer[k] = 0.125;
        r->height_m._buffer[k] = 0.5 * k;
        r->hazard._buffer[k] = k == 1;
      }
      rocks.push_back(r);
    }
    const auto js_bytes = serialize(pp, "export_test_js", js);
    const auto rock_bytes = serialize(pp, "export_test_rocks", rocks);
    for (auto* s : js) dds_sample_free(s, rd::MsgTraits<m::sensor_msgs::JointState>::descriptor(), DDS_FREE_ALL);
    for (auto* r : rocks) dds_sample_free(r, rd::MsgTraits<m::regolith_msgs::RockArray>::descriptor(), DDS_FREE_ALL);
    dds_delete(pp);
    ASSERT_EQ(js_bytes.size(), static_cast<std::size_t>(kJointStates));
    ASSERT_EQ(rock_bytes.size(), static_cast<std::size_t>(kRockArrays));

    regolith::record::McapWriter w(file_, {.compression = regolith::record::Compression::kNone, .chunk_size = 1024});
    const auto sj = w.add_schema("sensor_msgs/msg/JointState", "ros2msg", std::string());
    const auto sr = w.add_schema("regolith_msgs/msg/RockArray", "ros2msg", std::string());
    const auto cj = w.add_channel(sj, "/rover7/joint_states", "cdr", {});
    const auto cr = w.add_channel(sr, "/rover7/terrain/rocks", "cdr", {});
    for (int i = 0; i < kJointStates; ++i) {
      w.write(cj, static_cast<std::uint32_t>(i), 1000 + 10 * i, 900 + 10 * i, js_bytes[static_cast<std::size_t>(i)]);
      if (i < kRockArrays)
        w.write(cr, static_cast<std::uint32_t>(i), 1005 + 10 * i, 905 + 10 * i,
                rock_bytes[static_cast<std::size_t>(i)]);
    }
    w.close();
  }

  const regolith::testing::TempDir tmp_{"log_export"};  // one per test, removed whatever the outcome
  const fs::path& dir_ = tmp_.path();
  fs::path file_;
};

TEST_F(LogExport, JsonLinesFieldByField) {
  const fs::path out = dir_ / "out";
  const ExportRun r = run(file_.string() + " --topic joint_states --topic /rover7/terrain/rocks --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("/rover7/joint_states: 30 messages -> " + (out / "rover7_joint_states.jsonl").string()),
            std::string::npos)
      << r.out;
  EXPECT_NE(r.out.find("/rover7/terrain/rocks: 2 messages -> " + (out / "rover7_terrain_rocks.jsonl").string()),
            std::string::npos)
      << r.out;

  const auto jl = lines(out / "rover7_joint_states.jsonl");
  ASSERT_EQ(jl.size(), static_cast<std::size_t>(kJointStates));
  for (int i = 0; i < kJointStates; ++i) {
    const json j = json::parse(jl[static_cast<std::size_t>(i)]);
    EXPECT_EQ(j["sequence"], i);
    EXPECT_EQ(j["log_time_ns"], 1000 + 10 * i);
    EXPECT_EQ(j["publish_time_ns"], 900 + 10 * i);
    const json& msg = j["message"];
    EXPECT_EQ(msg["header"]["frame_id"], i == 7 ? "base\xEF\xBF\xBD_link" : "base_link");
    EXPECT_EQ(msg["header"]["stamp"]["sec"], 5);
    EXPECT_EQ(msg["header"]["stamp"]["nanosec"], i * 20000000);
    EXPECT_EQ(msg["name"], json({"wheel_0", "wheel_1", "wheel_2"}));
    EXPECT_EQ(msg["position"], json({0.25 * i, 0.25 * i + 1, 0.25 * i + 2}));
    EXPECT_EQ(msg["velocity"], json({0.0, -1.5, nullptr}));  // NaN -> null
    EXPECT_EQ(msg["effort"], json::array());
  }
  const auto rl = lines(out / "rover7_terrain_rocks.jsonl");
  ASSERT_EQ(rl.size(), static_cast<std::size_t>(kRockArrays));
  for (int i = 0; i < kRockArrays; ++i) {
    const json msg = json::parse(rl[static_cast<std::size_t>(i)])["message"];
    EXPECT_EQ(msg["header"]["frame_id"], "front_optical_frame");
    EXPECT_EQ(msg["header"]["stamp"]["nanosec"], (i + 1) * 1000000);
    ASSERT_EQ(msg["detections"].size(), 2U);
    for (int k = 0; k < 2; ++k) {
      const json& d = msg["detections"][static_cast<std::size_t>(k)];
      EXPECT_EQ(d["id"], "r" + std::to_string(i) + "_" + std::to_string(k));
      EXPECT_EQ(d["results"][0]["hypothesis"]["class_id"], "rock");
      EXPECT_EQ(d["results"][0]["hypothesis"]["score"], 0.5 + 0.25 * k);
      EXPECT_EQ(d["bbox"]["center"]["position"]["x"], 100.0 * i + k);
      EXPECT_EQ(d["bbox"]["size_x"], 10.0 + k);
    }
    EXPECT_EQ(msg["ground_range_m"], json({1.5 + i, 2.5 + i}));
    EXPECT_EQ(msg["lateral_offset_m"], json({0.0, -0.25}));
    EXPECT_EQ(msg["width_m"], json({0.125, 0.125}));
    EXPECT_EQ(msg["height_m"], json({0.0, 0.5}));
    EXPECT_EQ(msg["hazard"], json({false, true}));
  }
}

TEST_F(LogExport, CsvHeaderAndValues) {
  const fs::path out = dir_ / "csv";
  const ExportRun r = run(file_.string() + " --topic rover7/joint_states --format csv --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  const auto l = lines(out / "rover7_joint_states.csv");
  ASSERT_EQ(l.size(), static_cast<std::size_t>(kJointStates + 1));
  EXPECT_EQ(l[0],
            "log_time_ns,publish_time_ns,sequence,header.frame_id,header.stamp.nanosec,header.stamp.sec,"
            "name[0],name[1],name[2],position[0],position[1],position[2],velocity[0],velocity[1],velocity[2]");
  EXPECT_EQ(l[1], "1000,900,0,base_link,0,5,wheel_0,wheel_1,wheel_2,0.0,1.0,2.0,-0.0,-1.5,");  // -1.5 * 0 = -0.0, kept
  EXPECT_EQ(l[3], "1020,920,2,base_link,40000000,5,wheel_0,wheel_1,wheel_2,0.5,1.5,2.5,-0.0,-1.5,");
}

TEST_F(LogExport, UnknownTopicIsAUsageError) {
  const ExportRun r = run(file_.string() + " --topic nope --out " + (dir_ / "x").string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(r.out.find("no channel 'nope'"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("/rover7/joint_states  sensor_msgs/msg/JointState"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("/rover7/terrain/rocks  regolith_msgs/msg/RockArray"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "x"));
}

TEST_F(LogExport, TruncatedFileExportsTheCompleteChunks) {
  const auto size = fs::file_size(file_);
  fs::resize_file(file_, size / 2);
  const fs::path out = dir_ / "cut";
  const ExportRun r = run(file_.string() + " --topic joint_states --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("truncated at byte"), std::string::npos) << r.out;
  const auto jl = lines(out / "rover7_joint_states.jsonl");
  EXPECT_GT(jl.size(), 0U);
  EXPECT_LT(jl.size(), static_cast<std::size_t>(kJointStates));
  for (std::size_t i = 0; i < jl.size(); ++i) EXPECT_EQ(json::parse(jl[i])["sequence"], i);
}

TEST_F(LogExport, DamagedChunkIsReportedTheRestExported) {
  std::uint64_t chunk_offset = 0, chunk_length = 0;
  std::size_t chunks = 0;
  {
    regolith::record::McapReader reader(file_);
    chunks = reader.info().chunks.size();
    ASSERT_GE(chunks, 3U);
    chunk_offset = reader.info().chunks[1].offset;
    chunk_length = reader.info().chunks[1].length;
  }
  {
    std::fstream f(file_, std::ios::in | std::ios::out | std::ios::binary);
    f.seekg(static_cast<std::streamoff>(chunk_offset + chunk_length - 8));  // inside the last message's CDR
    char c = 0;
    f.get(c);
    f.seekp(static_cast<std::streamoff>(chunk_offset + chunk_length - 8));
    f.put(static_cast<char>(c ^ 0x5a));
  }
  const fs::path out = dir_ / "bad";
  const ExportRun r = run(file_.string() + " --topic joint_states --out " + out.string());
  EXPECT_EQ(r.status, 2) << r.out;
  EXPECT_NE(
      r.out.find("damaged: " + file_.string() + ": byte " + std::to_string(chunk_offset) + ": Chunk: CRC mismatch"),
      std::string::npos)
      << r.out;
  const auto jl = lines(out / "rover7_joint_states.jsonl");
  EXPECT_GT(jl.size(), 0U);
  EXPECT_LT(jl.size(), static_cast<std::size_t>(kJointStates));
  EXPECT_NE(r.out.find("/rover7/joint_states: " + std::to_string(jl.size()) + " messages"), std::string::npos) << r.out;
}

}  // namespace

// The camera previews (sensor_msgs/CompressedImage): each image's bytes become a file beside the
// JSON lines, named in the line's "file"; the message's data renders as its byte count.
TEST_F(LogExport, CompressedImagesBecomeFiles) {
  const dds_entity_t pp = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
  ASSERT_GT(pp, 0);
  std::vector<std::vector<std::uint8_t>> payloads = {{0xFF, 0xD8, 1, 2, 3, 0xFF, 0xD9}, {0xFF, 0xD8, 9, 8, 0xFF, 0xD9}};
  std::vector<m::sensor_msgs::CompressedImage*> images;
  for (std::size_t i = 0; i < payloads.size(); ++i) {
    auto* s = static_cast<m::sensor_msgs::CompressedImage*>(dds_alloc(sizeof(m::sensor_msgs::CompressedImage)));
    rd::reserve(*s, 64, 16, 32);
    rd::set_time(s->header.stamp, (i + 1) * regolith::kNsPerSec);
    rd::copy_string(s->header.frame_id, 32, "front_optical_frame");
    rd::copy_string(s->format, 16, "jpeg");
    rd::set_length(s->data, payloads[i].size());
    std::copy(payloads[i].begin(), payloads[i].end(), s->data._buffer);
    images.push_back(s);
  }
  const auto bytes = serialize(pp, "export_test_images", images);
  for (auto* s : images) dds_sample_free(s, rd::MsgTraits<m::sensor_msgs::CompressedImage>::descriptor(), DDS_FREE_ALL);
  dds_delete(pp);
  ASSERT_EQ(bytes.size(), payloads.size());
  const fs::path file = dir_ / "previews.mcap";
  {
    regolith::record::McapWriter w(file, {.compression = regolith::record::Compression::kNone, .chunk_size = 1024});
    const auto s = w.add_schema("sensor_msgs/msg/CompressedImage", "ros2msg", std::string());
    const auto c = w.add_channel(s, "/rover7/preview/rocks/compressed", "cdr", {});
    for (std::size_t i = 0; i < bytes.size(); ++i)
      w.write(c, static_cast<std::uint32_t>(i), 2000 + 10 * i, 1900 + 10 * i, bytes[i]);
    w.close();
  }
  const fs::path out = dir_ / "img";
  const ExportRun r = run(file.string() + " --topic /rover7/preview/rocks/compressed --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("(images in " + (out / "rover7_preview_rocks_compressed").string() + "/)"), std::string::npos)
      << r.out;
  const auto ls = lines(out / "rover7_preview_rocks_compressed.jsonl");
  ASSERT_EQ(ls.size(), payloads.size());
  for (std::size_t i = 0; i < ls.size(); ++i) {
    const json j = json::parse(ls[i]);
    EXPECT_EQ(j["message"]["format"], "jpeg");
    EXPECT_EQ(j["message"]["data"]["bytes"], payloads[i].size());
    const std::string name = j.at("file").get<std::string>();
    EXPECT_EQ(name, "rover7_preview_rocks_compressed/00000" + std::to_string(i) + ".jpg");
    std::ifstream in(out / name, std::ios::binary);
    const std::vector<std::uint8_t> got((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(got, payloads[i]) << name;
  }
}

namespace {

// The HAL recording's camera frames (sensor_msgs/Image, as `regolith run --record` writes them)
// become lossless PNG files named in their lines, pixel for pixel the recorded frames (grey and
// colour); its attitudes (geometry_msgs/Vector3Stamped) lines with roll, pitch and yaw; a damaged
// frame is counted and skipped, the others exported.
TEST_F(LogExport, HalFramesBecomePngFilesAndAttitudesLines) {
  cv::Mat grey(48, 64, CV_8UC1), colour(30, 40, CV_8UC3);
  cv::randu(grey, 0, 256);
  cv::randu(colour, cv::Scalar::all(0), cv::Scalar::all(256));
  std::vector<std::uint8_t> f0, f1, a0, damaged;
  regolith::record::encode_image(f0, 5 * regolith::kNsPerSec + 250, "front_optical_frame", grey);
  regolith::record::encode_image(f1, 6 * regolith::kNsPerSec, "front_optical_frame", colour);
  damaged.assign(f1.begin(), f1.begin() + 40);  // cut inside the header of the pixels
  regolith::record::encode_attitude(a0, 7 * regolith::kNsPerSec, regolith::Attitude{0.1, -0.2, 1.5});
  const fs::path file = dir_ / "hal.mcap";
  {
    regolith::record::McapWriter w(file, {.compression = regolith::record::Compression::kZstd, .chunk_size = 4096});
    const auto si = w.add_schema("sensor_msgs/msg/Image", "ros2msg", std::string());
    const auto sv = w.add_schema("geometry_msgs/msg/Vector3Stamped", "ros2msg", std::string());
    const auto ci = w.add_channel(si, "/hal/cameras/front/image", "cdr", {});
    const auto cv3 = w.add_channel(sv, "/hal/imus/body_imu/attitude", "cdr", {});
    w.write(ci, 0, 100, 100, f0);
    w.write(ci, 1, 110, 110, damaged);
    w.write(ci, 2, 120, 120, f1);
    w.write(cv3, 0, 130, 130, a0);
    w.close();
  }
  const fs::path out = dir_ / "hal";
  const ExportRun r = run(
      file.string() + " --topic /hal/cameras/front/image --topic /hal/imus/body_imu/attitude --out " + out.string());
  ASSERT_EQ(r.status, 0) << r.out;
  EXPECT_NE(r.out.find("/hal/cameras/front/image: 2 messages"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("(1 undecodable CDR payloads skipped)"), std::string::npos) << r.out;
  const auto ls = lines(out / "hal_cameras_front_image.jsonl");
  ASSERT_EQ(ls.size(), 2u);
  const cv::Mat want[2] = {grey, colour};
  for (std::size_t i = 0; i < 2; ++i) {
    const json j = json::parse(ls[i]);
    const json& msg = j["message"];
    EXPECT_EQ(msg["width"], want[i].cols);
    EXPECT_EQ(msg["height"], want[i].rows);
    EXPECT_EQ(msg["encoding"], i == 0 ? "mono8" : "bgr8");
    EXPECT_EQ(msg["header"]["frame_id"], "front_optical_frame");
    EXPECT_EQ(msg["data"]["bytes"], want[i].total() * want[i].elemSize());
    const std::string name = j.at("file").get<std::string>();
    EXPECT_EQ(name, "hal_cameras_front_image/00000" + std::to_string(i) + ".png");
    const cv::Mat png = cv::imread((out / name).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(png.type(), want[i].type()) << name;
    ASSERT_EQ(png.size(), want[i].size()) << name;
    EXPECT_EQ(cv::norm(png, want[i], cv::NORM_INF), 0.0) << name;
  }
  EXPECT_EQ(json::parse(ls[0])["message"]["header"]["stamp"], json({{"sec", 5}, {"nanosec", 250}}));
  const auto al = lines(out / "hal_imus_body_imu_attitude.jsonl");
  ASSERT_EQ(al.size(), 1u);
  const json v = json::parse(al[0])["message"];
  EXPECT_DOUBLE_EQ(v["vector"]["x"].get<double>(), 0.1);
  EXPECT_DOUBLE_EQ(v["vector"]["y"].get<double>(), -0.2);
  EXPECT_DOUBLE_EQ(v["vector"]["z"].get<double>(), 1.5);
  EXPECT_EQ(v["header"]["stamp"]["sec"], 7);
  // CSV: the same frames, the file in a column.
  const ExportRun c =
      run(file.string() + " --topic /hal/cameras/front/image --format csv --out " + (dir_ / "csv").string());
  ASSERT_EQ(c.status, 0) << c.out;
  const auto cl = lines(dir_ / "csv" / "hal_cameras_front_image.csv");
  ASSERT_EQ(cl.size(), 3u);
  EXPECT_NE(cl[0].find(",file"), std::string::npos) << cl[0];
  EXPECT_NE(cl[2].find("hal_cameras_front_image/000001.png"), std::string::npos) << cl[2];
}

}  // namespace
