// The independent check: files written by McapWriter (zstd chunks, uncompressed chunks, many
// channels, cut off mid-chunk) read by the MCAP authors' TypeScript reader @mcap/core through
// tests/record/mcap_js/validate.js (indexed reader and stream reader, CRCs checked): the topics
// and per-topic message counts must be those written (for a truncated file: those of the complete
// chunks, which the C++ reader reports too). Needs `npm ci` in tests/record/mcap_js
// (deploy/setup.sh does it).
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace regolith::record;

namespace {

/// A file in the directory of this run, shared by its tests and removed when the binary exits.
fs::path temp_file(const std::string& name) {
  static const regolith::testing::TempDir dir("test_mcap_js");
  return dir / name;
}

/// Runs validate.js; returns its exit status, its output in `out`.
int validate(const fs::path& file, bool complete, const std::map<std::string, std::uint64_t>& topics,
             const std::vector<std::string>& attachments, std::string& out) {
  const fs::path expected = fs::path(file).replace_extension(".json");
  {
    std::ofstream j(expected);
    j << "{\"complete\": " << (complete ? "true" : "false") << ", \"topics\": {";
    bool first = true;
    for (const auto& [t, n] : topics) {
      j << (first ? "" : ", ") << '"' << t << "\": " << n;
      first = false;
    }
    j << "}";
    if (!attachments.empty()) {
      j << ", \"attachments\": [";
      for (std::size_t i = 0; i < attachments.size(); ++i) j << (i ? ", " : "") << '"' << attachments[i] << '"';
      j << "]";
    }
    j << "}\n";
  }
  const std::string cmd = std::string(REGOLITH_NODE) + " " + REGOLITH_MCAP_JS_DIR + "/validate.js " + file.string() +
                          " " + expected.string() + " 2>&1";
  FILE* p = ::popen(cmd.c_str(), "r");
  if (p == nullptr) return -1;
  char buf[4096];
  std::size_t n = 0;
  out.clear();
  while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
  const int status = ::pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::vector<std::uint8_t> bytes_of(std::size_t n, std::uint32_t seed) {
  std::vector<std::uint8_t> b(n);
  for (std::size_t i = 0; i < n; ++i) b[i] = static_cast<std::uint8_t>((i / 7 + seed) & 0xFF);
  return b;
}

/// Three topics, a metadata record, the deployment as attachment. Returns messages per topic.
std::map<std::string, std::uint64_t> write_file(const fs::path& path, Compression c, std::uint64_t chunk_size,
                                                std::uint64_t split_bytes = 0, std::vector<fs::path>* files = nullptr) {
  McapWriterOptions o;
  o.compression = c;
  o.chunk_size = chunk_size;
  o.split_bytes = split_bytes;
  McapWriter w(path, o);
  const auto js = w.add_schema("sensor_msgs/msg/JointState", "ros2msg", std::string("float64[] position\n"));
  const auto img = w.add_schema("sensor_msgs/msg/Image", "ros2msg", std::string("uint8[] data\n"));
  const auto a = w.add_channel(js, "/rover1/joint_states", "cdr", {{"offered_qos_profiles", ""}});
  const auto b = w.add_channel(img, "/rover1/camera/front", "cdr");
  const auto d = w.add_channel(js, "/diagnostics", "cdr");
  w.add_metadata("regolith", {{"deployment", "mock_rover"}});
  const std::string yaml = "rate_groups: []\n";
  w.add_attachment("deployment.yaml", "application/yaml", 1, 0,
                   std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size()));
  std::map<std::string, std::uint64_t> n;
  for (std::uint32_t i = 0; i < 3000; ++i) {
    const std::uint64_t t = 5'000'000'000ULL + i * 1'000'000ULL;
    w.write(a, i, t, t, bytes_of(100, i));
    ++n["/rover1/joint_states"];
    if (i % 30 == 0) {
      w.write(b, i / 30, t, t, bytes_of(30000, i));
      ++n["/rover1/camera/front"];
    }
    if (i % 1000 == 999) {
      w.write(d, i / 1000, t, t, bytes_of(300, i));
      ++n["/diagnostics"];
    }
  }
  w.close();
  if (files != nullptr) *files = w.files();
  return n;
}

std::map<std::string, std::uint64_t> cpp_counts(const McapFileInfo& info) {
  std::map<std::string, std::uint64_t> m;
  for (const auto& [id, c] : info.channels) {
    const auto it = info.message_counts.find(id);
    m[c.topic] = it == info.message_counts.end() ? 0 : it->second;
  }
  return m;
}

void check_node_modules() {
  ASSERT_TRUE(fs::exists(fs::path(REGOLITH_MCAP_JS_DIR) / "node_modules" / "@mcap" / "core"))
      << "@mcap/core is not installed: run `npm ci` in " << REGOLITH_MCAP_JS_DIR << " (deploy/setup.sh does it)";
}

}  // namespace

class McapJs : public ::testing::TestWithParam<Compression> {};

TEST_P(McapJs, CompleteFileReadByIndexedAndStreamReaders) {
  check_node_modules();
  const fs::path path = temp_file(std::string("complete_") + compression_name(GetParam()) + "x.mcap");
  const auto topics = write_file(path, GetParam(), 256 * 1024);
  ASSERT_EQ(cpp_counts(McapReader(path).info()), topics);
  std::string out;
  EXPECT_EQ(validate(path, true, topics, {"deployment.yaml"}, out), 0) << out;
}

TEST_P(McapJs, TruncatedFileReadByStreamReaderUpToTheLastCompleteChunk) {
  check_node_modules();
  const fs::path full = temp_file(std::string("full_") + compression_name(GetParam()) + "x.mcap");
  const auto topics = write_file(full, GetParam(), 256 * 1024);
  const auto chunks = McapReader(full).info().chunks;
  ASSERT_GE(chunks.size(), 3U);
  // Cut in the middle of the third chunk (power loss while it was being written).
  const std::uint64_t cut_at = chunks[2].offset + chunks[2].length / 2;
  std::vector<std::uint8_t> bytes(static_cast<std::size_t>(fs::file_size(full)));
  {
    std::ifstream in(full, std::ios::binary);
    in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  const fs::path cut = temp_file(std::string("cut_") + compression_name(GetParam()) + "x.mcap");
  {
    std::ofstream o(cut, std::ios::binary);
    o.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(cut_at));
  }
  McapReader r(cut);
  ASSERT_TRUE(r.info().truncated);
  EXPECT_EQ(r.info().readable_end, chunks[2].offset);
  EXPECT_EQ(r.info().chunks.size(), 2U);
  const auto expected = cpp_counts(r.info());
  EXPECT_LT(expected.at("/rover1/joint_states"), topics.at("/rover1/joint_states"));
  std::string out;
  EXPECT_EQ(validate(cut, false, expected, {}, out), 0) << out;
}

TEST_P(McapJs, EveryFileOfASplitRecordingIsReadOnItsOwn) {
  check_node_modules();
  const fs::path path = temp_file(std::string("split_") + compression_name(GetParam()) + "x.mcap");
  std::vector<fs::path> files;
  const auto topics =
      write_file(path, GetParam(), 64 * 1024, GetParam() == Compression::kNone ? 300 * 1024 : 48 * 1024, &files);
  ASSERT_GE(files.size(), 2U);
  std::map<std::string, std::uint64_t> sum;
  for (const auto& f : files) {
    const auto counts = cpp_counts(McapReader(f).info());
    for (const auto& [t, n] : counts) sum[t] += n;
    std::string out;
    EXPECT_EQ(validate(f, true, counts, {"deployment.yaml"}, out), 0) << f << "\n" << out;
  }
  EXPECT_EQ(sum, topics);
}

INSTANTIATE_TEST_SUITE_P(Compression, McapJs, ::testing::Values(Compression::kZstd, Compression::kNone),
                         [](const auto& i) { return i.param == Compression::kZstd ? "zstd" : "none"; });

TEST(McapJsCheck, AMismatchIsReported) {
  check_node_modules();
  const fs::path path = temp_file("mismatch.mcap");
  auto topics = write_file(path, Compression::kZstd, 1U << 20);
  topics["/rover1/joint_states"] += 1;
  std::string out;
  EXPECT_EQ(validate(path, true, topics, {}, out), 1) << out;
  EXPECT_NE(out.find("topic /rover1/joint_states: 3000 messages, expected 3001"), std::string::npos) << out;
}

TEST(McapJsCheck, ManyChannels) {
  check_node_modules();
  const fs::path path = temp_file("many_channels.mcap");
  std::map<std::string, std::uint64_t> topics;
  {
    McapWriterOptions o;
    o.chunk_size = 8192;
    McapWriter w(path, o);
    const auto s = w.add_schema("std_msgs/msg/String", "ros2msg", std::string("string data\n"));
    for (int i = 0; i < 300; ++i) {
      const std::string topic = "/t" + std::to_string(i);
      const auto c = w.add_channel(s, topic, "cdr");
      for (std::uint32_t k = 0; k <= static_cast<std::uint32_t>(i % 5); ++k) {
        w.write(c, k, 1000 + k * 300 + static_cast<std::uint64_t>(i), 0, bytes_of(20, k));
        ++topics[topic];
      }
    }
    w.close();
  }
  std::string out;
  EXPECT_EQ(validate(path, true, topics, {}, out), 0) << out;
}
