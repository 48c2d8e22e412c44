// regolith::record: McapWriter / McapReader round trips with and without zstd, many channels,
// files cut off at every byte, damaged CRCs, wrong magic, and the `regolith log info` text.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "regolith/core/error.hpp"
#include "regolith/record/crc32.hpp"
#include "regolith/record/info.hpp"
#include "regolith/record/mcap_reader.hpp"
#include "regolith/record/mcap_writer.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace regolith::record;

namespace {

/// A file in the directory of this run, shared by its tests and removed when the binary exits.
fs::path temp_file(const std::string& name) {
  static const regolith::testing::TempDir dir("test_record");
  return dir / name;
}

std::vector<std::uint8_t> read_all(const fs::path& p) {
  std::vector<std::uint8_t> b(static_cast<std::size_t>(fs::file_size(p)));
  std::ifstream in(p, std::ios::binary);
  in.read(reinterpret_cast<char*>(b.data()), static_cast<std::streamsize>(b.size()));
  return b;
}

void write_all(const fs::path& p, const std::vector<std::uint8_t>& bytes, std::size_t n) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(n));
}

std::vector<std::uint8_t> payload(std::uint16_t channel, std::uint32_t seq, std::size_t size) {
  std::vector<std::uint8_t> p(size);
  for (std::size_t i = 0; i < size; ++i) p[i] = static_cast<std::uint8_t>((channel * 31 + seq * 7 + i) & 0xFF);
  return p;
}

struct Received {
  std::uint16_t channel;
  std::uint32_t seq;
  std::uint64_t log_time, publish_time;
  std::vector<std::uint8_t> data;
};

std::vector<Received> read_messages(McapReader& r, std::vector<ReadProblem>* problems = nullptr) {
  std::vector<Received> out;
  auto p = r.for_each_message([&](const MessageView& m) {
    out.push_back({m.channel.id, m.sequence, m.log_time, m.publish_time, {m.data.begin(), m.data.end()}});
  });
  if (problems != nullptr) *problems = std::move(p);
  return out;
}

const char* kJointStateMsg = "string[] name\nfloat64[] position\nfloat64[] velocity\nfloat64[] effort\n";

/// A recording like the rover's: 3 channels at different rates and sizes, a metadata record and the
/// deployment as an attachment. Returns messages per channel id.
std::map<std::uint16_t, std::uint64_t> write_rover_like(const fs::path& path, Compression c, std::uint64_t chunk_size,
                                                        int seconds = 2) {
  McapWriterOptions o;
  o.compression = c;
  o.chunk_size = chunk_size;
  o.library = "regolith test";
  McapWriter w(path, o);
  const auto js = w.add_schema("sensor_msgs/msg/JointState", "ros2msg", std::string(kJointStateMsg));
  const auto img = w.add_schema("sensor_msgs/msg/Image", "ros2msg", std::string("uint32 height\nuint32 width\n"));
  const auto joints = w.add_channel(js, "/rover1/joint_states", "cdr", {{"offered_qos_profiles", ""}});
  const auto cam = w.add_channel(img, "/rover1/camera/front", "cdr");
  const auto imu = w.add_channel(js, "/rover1/imu", "cdr");
  w.add_metadata("regolith", {{"deployment", "mock_rover"}, {"version", "0.1.0"}});
  const std::string yaml = "rate_groups:\n  - name: fast\n    period_ms: 10\n";
  w.add_attachment("deployment.yaml", "application/yaml", 5, 4,
                   std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size()));
  std::map<std::uint16_t, std::uint64_t> n;
  std::uint32_t seq_j = 0, seq_c = 0, seq_i = 0;
  for (std::uint64_t t = 0; t < static_cast<std::uint64_t>(seconds) * 1000; ++t) {  // 1 ms steps
    const std::uint64_t ns = 1'000'000'000ULL + t * 1'000'000ULL;
    if (t % 10 == 0) {
      w.write(joints, seq_j, ns, ns - 100, payload(joints, seq_j, 120));
      ++seq_j;
      ++n[joints];
    }
    if (t % 100 == 0) {
      w.write(cam, seq_c, ns, ns - 200, payload(cam, seq_c, 20000));
      ++seq_c;
      ++n[cam];
    }
    if (t % 5 == 0) {
      w.write(imu, seq_i, ns, ns, payload(imu, seq_i, 48));
      ++seq_i;
      ++n[imu];
    }
  }
  w.close();
  return n;
}

}  // namespace

TEST(McapCrc, MatchesZlibCheckValue) {
  const char* s = "123456789";
  EXPECT_EQ(crc32(s, 9), 0xCBF43926U);  // the CRC-32/ISO-HDLC check value
  EXPECT_EQ(crc32_update(crc32(s, 4), s + 4, 5), 0xCBF43926U);
  std::vector<std::uint8_t> big(1000);
  for (std::size_t i = 0; i < big.size(); ++i) big[i] = static_cast<std::uint8_t>(i * 13);
  std::uint32_t piecewise = 0;
  for (std::size_t i = 0; i < big.size(); i += 7)
    piecewise = crc32_update(piecewise, big.data() + i, std::min<std::size_t>(7, big.size() - i));
  EXPECT_EQ(piecewise, crc32(big.data(), big.size()));
  for (const std::size_t split : {0UL, 1UL, 7UL, 8UL, 500UL, 999UL, 1000UL})
    EXPECT_EQ(
        crc32_combine(crc32(big.data(), split), crc32(big.data() + split, big.size() - split), big.size() - split),
        crc32(big.data(), big.size()))
        << split;
}

class McapRoundTrip : public ::testing::TestWithParam<Compression> {};

TEST_P(McapRoundTrip, EverythingWrittenIsReadBack) {
  const fs::path path =
      temp_file(std::string("round_trip_") + (GetParam() == Compression::kZstd ? "zstd" : "none") + ".mcap");
  const auto expected = write_rover_like(path, GetParam(), 64 * 1024);

  for (const bool summary : {true, false}) {
    SCOPED_TRACE(summary ? "summary" : "scan");
    McapReaderOptions o;
    o.use_summary = summary;
    McapReader r(path, o);
    const McapFileInfo& info = r.info();
    EXPECT_EQ(info.from_summary, summary);
    EXPECT_FALSE(info.truncated);
    EXPECT_TRUE(info.problems.empty()) << r.describe(info.problems.front());
    EXPECT_EQ(info.profile, "ros2");
    EXPECT_EQ(info.library, "regolith test");
    ASSERT_EQ(info.schemas.size(), 2U);
    EXPECT_EQ(info.schemas.at(1).name, "sensor_msgs/msg/JointState");
    EXPECT_EQ(info.schemas.at(1).encoding, "ros2msg");
    EXPECT_EQ(std::string(info.schemas.at(1).data.begin(), info.schemas.at(1).data.end()), kJointStateMsg);
    ASSERT_EQ(info.channels.size(), 3U);
    EXPECT_EQ(info.channels.at(1).topic, "/rover1/joint_states");
    EXPECT_EQ(info.channels.at(1).message_encoding, "cdr");
    EXPECT_EQ(info.channels.at(1).metadata.at("offered_qos_profiles"), "");
    EXPECT_EQ(info.channels.at(2).schema_id, 2);
    EXPECT_EQ(info.channels.at(2).metadata, (std::map<std::string, std::string>{{"offered_qos_profiles", ""}}));
    EXPECT_EQ(info.message_counts, expected);
    EXPECT_EQ(info.message_count, 200U + 20U + 400U);
    EXPECT_EQ(info.message_start_time, 1'000'000'000ULL);
    EXPECT_EQ(info.message_end_time, 1'000'000'000ULL + 1995 * 1'000'000ULL);
    EXPECT_GT(info.chunks.size(), 3U);
    for (const auto& c : info.chunks) EXPECT_EQ(c.compression, GetParam() == Compression::kZstd ? "zstd" : "");
    ASSERT_EQ(info.metadata.size(), 1U);
    EXPECT_EQ(info.metadata[0].name, "regolith");
    EXPECT_EQ(info.metadata[0].values.at("deployment"), "mock_rover");
    ASSERT_EQ(info.attachments.size(), 1U);
    EXPECT_EQ(info.attachments[0].name, "deployment.yaml");
    EXPECT_EQ(info.attachments[0].media_type, "application/yaml");
    const auto yaml = r.read_attachment(info.attachments[0]);
    EXPECT_EQ(std::string(yaml.begin(), yaml.end()), "rate_groups:\n  - name: fast\n    period_ms: 10\n");

    std::vector<ReadProblem> problems;
    const auto msgs = read_messages(r, &problems);
    EXPECT_TRUE(problems.empty());
    ASSERT_EQ(msgs.size(), info.message_count);
    std::map<std::uint16_t, std::uint32_t> next_seq;
    std::uint64_t last_time = 0;
    for (const auto& m : msgs) {
      EXPECT_EQ(m.seq, next_seq[m.channel]++) << "channel " << m.channel;  // per channel in order, none lost
      EXPECT_GE(m.log_time, last_time);  // written in time order, so read in time order
      last_time = m.log_time;
      const std::size_t size = m.channel == 1 ? 120 : m.channel == 2 ? 20000 : 48;
      EXPECT_EQ(m.data, payload(m.channel, m.seq, size));
      EXPECT_EQ(m.publish_time, m.log_time - (m.channel == 1 ? 100 : m.channel == 2 ? 200 : 0));
    }
  }
  if (GetParam() == Compression::kZstd) {  // the camera payloads are compressible
    EXPECT_LT(fs::file_size(path), 200U * 1024U);
  }
}

INSTANTIATE_TEST_SUITE_P(Compression, McapRoundTrip, ::testing::Values(Compression::kZstd, Compression::kNone),
                         [](const auto& i) { return i.param == Compression::kZstd ? "zstd" : "none"; });

TEST(McapRecord, StopEndsTheIterationOnTheSummaryAndTheScanPath) {
  // A reader looking for one message (`assess REC.mcap --frame N`) stops after it: later chunks are
  // not decompressed. Both paths: the summary (complete file) and the scan (file cut off).
  const fs::path path = temp_file("stop.mcap");
  write_rover_like(path, Compression::kZstd, 4096);
  const std::vector<std::uint8_t> bytes = read_all(path);
  const fs::path cut = temp_file("stop_cut.mcap");
  write_all(cut, bytes, bytes.size() - 100);
  for (const fs::path& p : {path, cut}) {
    McapReader r(p);
    ASSERT_GT(r.info().chunks.size(), 3u) << p;
    std::size_t calls = 0;
    const auto problems = r.for_each_message([&](const MessageView&) {
      if (++calls == 5) r.stop();
    });
    EXPECT_TRUE(problems.empty()) << p;
    EXPECT_EQ(calls, 5u) << p;
    std::size_t all = 0;  // the next iteration reads everything again
    (void)r.for_each_message([&](const MessageView&) { ++all; });
    EXPECT_EQ(all, r.info().message_count) << p;
  }
}

TEST(McapRecord, ManyChannelsAndOutOfOrderTimes) {
  const fs::path path = temp_file("many.mcap");
  {
    McapWriterOptions o;
    o.chunk_size = 4096;
    McapWriter w(path, o);
    const auto s = w.add_schema("std_msgs/msg/String", "ros2msg", std::string("string data\n"));
    for (int i = 0; i < 500; ++i) w.add_channel(s, "/topic_" + std::to_string(i), "cdr");
    for (std::uint32_t k = 0; k < 3; ++k)
      for (std::uint16_t c = 1; c <= 500; ++c) {
        // times go backwards inside each round: the reader must give them in log-time order per chunk
        const std::uint64_t t = 1000 * (k + 1) + (500 - c);
        w.write(c, k, t, t, payload(c, k, 10));
      }
    EXPECT_EQ(w.stats().messages, 1500U);
    w.close();
  }
  McapReader r(path);
  ASSERT_TRUE(r.info().from_summary);
  EXPECT_EQ(r.info().channels.size(), 500U);
  for (std::uint16_t c = 1; c <= 500; ++c) EXPECT_EQ(r.info().message_counts.at(c), 3U);
  EXPECT_EQ(r.info().channels.at(500).topic, "/topic_499");
  std::uint64_t n = 0;
  const auto problems = r.for_each_message([&](const MessageView& m) {
    ++n;
    EXPECT_EQ(m.data.size(), 10U);
    EXPECT_EQ(m.sequence, (m.log_time / 1000) - 1);
  });
  EXPECT_EQ(n, 1500U);
  EXPECT_TRUE(problems.empty());
  McapReader scan(path, {.verify_crcs = true, .use_summary = false});
  EXPECT_EQ(scan.info().message_count, 1500U);
  EXPECT_EQ(scan.info().message_counts, r.info().message_counts);
  EXPECT_EQ(scan.info().chunks.size(), r.info().chunks.size());
  EXPECT_GT(scan.info().chunks.size(), 3U);
}

TEST(McapRecord, MessagesOfAChunkComeInLogTimeOrder) {
  const fs::path path = temp_file("order.mcap");
  {
    McapWriter w(path);
    const auto c = w.add_channel(0, "/t", "cdr");
    for (std::uint32_t i = 0; i < 50; ++i) w.write(c, i, 1000 - i * 10, 0, payload(c, i, 4));  // one chunk, backwards
    w.close();
  }
  McapReader r(path);
  ASSERT_EQ(r.info().chunks.size(), 1U);
  const auto msgs = read_messages(r);
  ASSERT_EQ(msgs.size(), 50U);
  for (std::size_t i = 0; i < msgs.size(); ++i) EXPECT_EQ(msgs[i].seq, 49 - i);
  EXPECT_EQ(r.info().message_start_time, 510U);
  EXPECT_EQ(r.info().message_end_time, 1000U);
}

// A small file (a few chunks) cut off after every byte: the reader never throws anything but
// InputError (only before the Header is complete), never crashes, reports the truncation and
// reads every message of every complete chunk.
class McapTruncation : public ::testing::TestWithParam<Compression> {};

TEST_P(McapTruncation, CutAtEveryOffset) {
  const fs::path path =
      temp_file(std::string("small_") + (GetParam() == Compression::kZstd ? "zstd" : "none") + ".mcap");
  constexpr std::uint32_t kMessages = 23;
  constexpr std::size_t kPayload = 40;       // a Message record is 9 + 22 + 40 = 71 bytes
  constexpr std::uint64_t kChunkSize = 200;  // -> 3 messages per chunk (213 >= 200)
  {
    McapWriterOptions o;
    o.compression = GetParam();
    o.chunk_size = kChunkSize;
    McapWriter w(path, o);
    const auto s = w.add_schema("std_msgs/msg/String", "ros2msg", std::string("string data\n"));
    const auto a = w.add_channel(s, "/a", "cdr");
    const auto b = w.add_channel(s, "/b", "cdr");
    for (std::uint32_t i = 0; i < kMessages; ++i)
      w.write(i % 2 == 0 ? a : b, i, 100 + i, 100 + i, payload(a, i, kPayload));
    w.close();
  }
  const std::vector<std::uint8_t> full = read_all(path);
  McapReader whole(path);
  ASSERT_TRUE(whole.info().from_summary);
  const auto& chunks = whole.info().chunks;
  ASSERT_EQ(chunks.size(), 8U);  // ceil(23 / 3)
  std::size_t header_end = 0;
  for (std::size_t cut = 0; cut <= full.size(); ++cut) {
    SCOPED_TRACE("cut at " + std::to_string(cut) + " of " + std::to_string(full.size()));
    std::vector<std::uint8_t> part(full.begin(), full.begin() + static_cast<std::ptrdiff_t>(cut));
    std::unique_ptr<McapReader> r;
    try {
      r = std::make_unique<McapReader>(std::move(part), "cut.mcap");
    } catch (const regolith::InputError& e) {
      EXPECT_EQ(header_end, 0U) << "InputError after the Header was readable: " << e.what();
      EXPECT_NE(std::string(e.what()).find("cut.mcap: byte "), std::string::npos) << e.what();
      continue;
    }
    if (header_end == 0) header_end = cut;
    // messages of the complete chunks
    std::uint64_t expected = 0;
    for (std::size_t i = 0; i < chunks.size(); ++i)
      if (chunks[i].offset + chunks[i].length <= cut) expected += std::min<std::uint64_t>(3, kMessages - 3 * i);
    const McapFileInfo& info = r->info();
    EXPECT_EQ(info.message_count, expected);
    EXPECT_TRUE(info.problems.empty()) << r->describe(info.problems.front());
    if (cut == full.size()) {
      EXPECT_FALSE(info.truncated);
      EXPECT_TRUE(info.from_summary);
    } else {
      EXPECT_TRUE(info.truncated);
      EXPECT_LE(info.readable_end, cut);
      EXPECT_GE(info.readable_end, header_end);
      EXPECT_EQ(info.channels.size(), cut >= chunks[0].offset ? 2U : info.channels.size());
    }
    std::uint64_t n = 0;
    const auto problems = r->for_each_message([&](const MessageView& m) {
      EXPECT_EQ(m.data.size(), kPayload);
      ++n;
    });
    EXPECT_EQ(n, expected);
    EXPECT_TRUE(problems.empty());
  }
  EXPECT_EQ(header_end, 8U + 9U + 4U + 4U + 4U + 8U);  // magic + Header("ros2", "regolith")
}

INSTANTIATE_TEST_SUITE_P(Compression, McapTruncation, ::testing::Values(Compression::kZstd, Compression::kNone),
                         [](const auto& i) { return i.param == Compression::kZstd ? "zstd" : "none"; });

TEST(McapDamage, ChunkCrcMismatchNamesTheOffsetAndSkipsOnlyThatChunk) {
  const fs::path path = temp_file("crc.mcap");
  McapWriterOptions o;
  o.compression = Compression::kNone;
  o.chunk_size = 200;
  {
    McapWriter w(path, o);
    const auto c = w.add_channel(0, "/a", "cdr");
    for (std::uint32_t i = 0; i < 9; ++i) w.write(c, i, i, i, payload(c, i, 40));  // 3 chunks of 3
    w.close();
  }
  std::vector<std::uint8_t> bytes = read_all(path);
  const ChunkInfo second = McapReader(path).info().chunks.at(1);
  bytes[second.offset + second.length - 5] ^= 0x40;  // inside the last message's payload
  const fs::path bad = temp_file("crc_bad.mcap");
  write_all(bad, bytes, bytes.size());

  // Summary path: the summary is intact; reading the messages finds the damaged chunk.
  McapReader r(bad);
  EXPECT_TRUE(r.info().from_summary);
  std::vector<ReadProblem> problems;
  const auto msgs = read_messages(r, &problems);
  EXPECT_EQ(msgs.size(), 6U);
  ASSERT_EQ(problems.size(), 1U);
  EXPECT_EQ(problems[0].offset, second.offset);
  EXPECT_NE(problems[0].what.find("CRC mismatch"), std::string::npos) << problems[0].what;
  EXPECT_EQ(r.describe(problems[0])
                .rfind(bad.string() + ": byte " + std::to_string(second.offset) + ": Chunk: CRC mismatch", 0),
            0U)
      << r.describe(problems[0]);

  // Scan path: the damage is in info().problems, the other chunks are counted; the data-section
  // CRC in DataEnd does not match either.
  McapReader s(bad, {.verify_crcs = true, .use_summary = false});
  EXPECT_EQ(s.info().message_count, 6U);
  EXPECT_EQ(s.info().chunks.size(), 2U);
  ASSERT_EQ(s.info().problems.size(), 2U);
  EXPECT_EQ(s.info().problems[0].offset, second.offset);
  EXPECT_NE(s.info().problems[1].what.find("data section CRC mismatch"), std::string::npos);
  EXPECT_NE(format_info(s.info()).find("damaged:     byte " + std::to_string(second.offset) + ": Chunk: CRC mismatch"),
            std::string::npos)
      << format_info(s.info());

  // Without CRC checks the damaged bytes are delivered.
  McapReader unchecked(bad, {.verify_crcs = false, .use_summary = true});
  EXPECT_EQ(read_messages(unchecked).size(), 9U);
}

TEST(McapDamage, DamagedZstdChunkAndSummaryAreReported) {
  const fs::path path = temp_file("zstd_damage.mcap");
  McapWriterOptions o;
  o.chunk_size = 200;
  {
    McapWriter w(path, o);
    const auto c = w.add_channel(0, "/a", "cdr");
    for (std::uint32_t i = 0; i < 9; ++i) w.write(c, i, i, i, payload(c, i, 40));
    w.close();
  }
  const std::vector<std::uint8_t> good = read_all(path);
  const McapReader ref(path);
  const ChunkInfo first = ref.info().chunks.at(0);
  // Every byte of the first chunk's compressed records flipped in turn: reported or harmless, never a crash.
  for (std::uint64_t at = first.offset + first.length - first.compressed_size; at < first.offset + first.length; ++at) {
    std::vector<std::uint8_t> bytes = good;
    bytes[at] ^= 0xFF;
    McapReader r(std::move(bytes), "z.mcap");
    std::vector<ReadProblem> problems;
    const auto msgs = read_messages(r, &problems);
    if (!problems.empty()) {
      EXPECT_EQ(problems[0].offset, first.offset);
      EXPECT_EQ(msgs.size(), 6U);
    } else {
      EXPECT_EQ(msgs.size(), 9U);
    }
  }
  // A damaged summary: the CRC in the Footer catches it and the reader scans instead.
  std::vector<std::uint8_t> bytes = good;
  std::uint64_t summary_start = 0;
  for (int i = 7; i >= 0; --i)
    summary_start = (summary_start << 8) | bytes[bytes.size() - 8 - 20 + static_cast<std::size_t>(i)];
  bytes[summary_start + 12] ^= 0x01;
  McapReader r(std::move(bytes), "s.mcap");
  EXPECT_FALSE(r.info().from_summary);
  EXPECT_FALSE(r.info().truncated);
  EXPECT_EQ(r.info().message_count, 9U);
  ASSERT_EQ(r.info().problems.size(), 1U);
  EXPECT_EQ(r.info().problems[0].offset, summary_start);
  EXPECT_NE(r.info().problems[0].what.find("summary CRC mismatch"), std::string::npos);
}

TEST(McapDamage, WrongMagicEmptyAndMissingFilesAreInputErrors) {
  const fs::path png = temp_file("image.mcap");
  {
    std::ofstream out(png, std::ios::binary);
    out << "\x89PNG\r\n\x1a\n0000000000000000000000000";
  }
  try {
    McapReader r(png);
    FAIL() << "no error";
  } catch (const regolith::InputError& e) {
    EXPECT_EQ(std::string(e.what()), png.string() +
                                         ": byte 0: not an MCAP file: wrong magic 89 50 4e 47 0d 0a 1a 0a "
                                         "(expected 89 4d 43 41 50 30 0d 0a)");
  }
  const fs::path empty = temp_file("empty.mcap");
  { std::ofstream out(empty); }
  EXPECT_THROW(McapReader{empty}, regolith::InputError);
  EXPECT_THROW(McapReader{temp_file("missing.mcap")}, regolith::InputError);
  // Magic followed by something other than a Header.
  std::vector<std::uint8_t> b(kMcapMagic.begin(), kMcapMagic.end());
  b.insert(b.end(), {0x05, 1, 0, 0, 0, 0, 0, 0, 0, 0});
  try {
    McapReader r(b, "x.mcap");
    FAIL() << "no error";
  } catch (const regolith::InputError& e) {
    EXPECT_EQ(std::string(e.what()), "x.mcap: byte 8: expected a Header record after the magic, found Message");
  }
}

// Another writer's layout: Schema, Channel and Message records straight in the data section (no
// chunks), a Statistics-only summary. The summary cannot locate such messages, so the reader scans.
TEST(McapRecord, MessagesOutsideChunksFromOtherWriters) {
  std::vector<std::uint8_t> f(kMcapMagic.begin(), kMcapMagic.end());
  auto u16 = [&](std::uint16_t v) {
    for (int i = 0; i < 2; ++i) f.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  auto u32 = [&](std::uint32_t v) {
    for (int i = 0; i < 4; ++i) f.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  auto u64 = [&](std::uint64_t v) {
    for (int i = 0; i < 8; ++i) f.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
  };
  auto str = [&](const std::string& v) {
    u32(static_cast<std::uint32_t>(v.size()));
    f.insert(f.end(), v.begin(), v.end());
  };
  std::size_t len_at = 0;
  auto begin = [&](Opcode op) {
    f.push_back(static_cast<std::uint8_t>(op));
    len_at = f.size();
    u64(0);
  };
  auto end = [&] {
    const std::uint64_t n = f.size() - len_at - 8;
    for (int i = 0; i < 8; ++i) f[len_at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(n >> (8 * i));
  };
  begin(Opcode::kHeader);
  str("");
  str("other writer");
  end();
  begin(Opcode::kSchema);
  u16(7);
  str("pkg/msg/T");
  str("ros2msg");
  u32(0);
  end();
  begin(Opcode::kChannel);
  u16(0);  // channel id 0 is valid
  u16(7);
  str("/loose");
  str("cdr");
  u32(0);
  end();
  for (std::uint32_t i = 0; i < 4; ++i) {
    begin(Opcode::kMessage);
    u16(0);
    u32(i);
    u64(50 - i);
    u64(50 - i);
    f.push_back(static_cast<std::uint8_t>(i));
    end();
  }
  begin(Opcode::kDataEnd);
  u32(0);  // no CRC
  end();
  const std::uint64_t summary_start = f.size();
  begin(Opcode::kStatistics);
  u64(4);
  u16(1);
  u32(1);
  u32(0);
  u32(0);
  u32(0);
  u64(47);
  u64(50);
  u32(0);
  end();
  begin(Opcode::kFooter);
  u64(summary_start);
  u64(0);
  u32(0);
  end();
  f.insert(f.end(), kMcapMagic.begin(), kMcapMagic.end());

  McapReader r(f, "other.mcap");
  EXPECT_FALSE(r.info().from_summary);  // messages, but no Chunk Index: scanned
  EXPECT_FALSE(r.info().truncated);
  EXPECT_TRUE(r.info().problems.empty());
  EXPECT_EQ(r.info().profile, "");
  EXPECT_EQ(r.info().library, "other writer");
  EXPECT_EQ(r.info().message_counts.at(0), 4U);
  EXPECT_EQ(r.info().message_start_time, 47U);
  EXPECT_EQ(r.info().channels.at(0).topic, "/loose");
  EXPECT_EQ(r.info().schemas.at(7).name, "pkg/msg/T");
  const auto msgs = read_messages(r);
  ASSERT_EQ(msgs.size(), 4U);
  for (std::uint32_t i = 0; i < 4; ++i) {  // outside chunks: file order
    EXPECT_EQ(msgs[i].seq, i);
    EXPECT_EQ(msgs[i].data, std::vector<std::uint8_t>{static_cast<std::uint8_t>(i)});
  }
}

TEST(McapWriterApi, RejectsUnknownIdsAndBadOptions) {
  const fs::path path = temp_file("api.mcap");
  McapWriter w(path);
  EXPECT_THROW(w.add_channel(3, "/x", "cdr"), std::invalid_argument);
  const auto c = w.add_channel(0, "/x", "cdr");
  EXPECT_THROW(w.write(static_cast<std::uint16_t>(c + 1), 0, 0, 0, {}), std::invalid_argument);
  w.close();
  w.close();  // idempotent
  EXPECT_THROW(w.write(c, 0, 0, 0, {}), std::logic_error);
  McapWriterOptions o;
  o.zstd_level = 0;
  EXPECT_THROW(McapWriter(temp_file("bad.mcap"), o), regolith::FieldError);
  EXPECT_THROW(McapWriter(fs::path("/nonexistent_dir/x.mcap")), std::runtime_error);
  // An empty recording is a valid file.
  McapReader r(path);
  EXPECT_TRUE(r.info().from_summary);
  EXPECT_EQ(r.info().message_count, 0U);
  EXPECT_EQ(r.info().channels.size(), 1U);
}

TEST(LogInfo, DescribesChannelsCountsChunksAndTruncation) {
  const fs::path path = temp_file("info.mcap");
  write_rover_like(path, Compression::kZstd, 64 * 1024);
  McapReader r(path);
  const std::string text = format_info(r.info());
  EXPECT_NE(text.find("profile:     ros2\n"), std::string::npos) << text;
  EXPECT_NE(text.find("library:     regolith test\n"), std::string::npos) << text;
  EXPECT_NE(text.find("messages:    620\n"), std::string::npos) << text;
  EXPECT_NE(text.find("time range:  1.000000000 .. 2.995000000 s (log time)\n"), std::string::npos) << text;
  EXPECT_NE(text.find("duration:    1.995 s\n"), std::string::npos) << text;
  EXPECT_NE(text.find("chunks:      " + std::to_string(r.info().chunks.size()) + " (zstd " +
                      std::to_string(r.info().chunks.size()) + ")"),
            std::string::npos)
      << text;
  EXPECT_NE(text.find("      1  /rover1/joint_states  sensor_msgs/msg/JointState  cdr       200\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("      2  /rover1/camera/front  sensor_msgs/msg/Image       cdr       20\n"), std::string::npos)
      << text;
  EXPECT_NE(text.find("attachment:  deployment.yaml (application/yaml, 46 B)\n"), std::string::npos) << text;
  EXPECT_NE(text.find("metadata:    regolith: deployment=mock_rover, version=0.1.0\n"), std::string::npos) << text;
  EXPECT_EQ(text.find("truncated"), std::string::npos) << text;

  std::vector<std::uint8_t> bytes = read_all(path);
  const ChunkInfo last = r.info().chunks.back();
  const fs::path cut = temp_file("info_cut.mcap");
  write_all(cut, bytes, last.offset + 100);  // inside the last chunk
  McapReader t(cut);
  const std::string ttext = format_info(t.info());
  EXPECT_NE(ttext.find("truncated at byte " + std::to_string(last.offset) + " of " + std::to_string(last.offset + 100)),
            std::string::npos)
      << ttext;
  EXPECT_NE(ttext.find("index:       none used: data section scanned"), std::string::npos) << ttext;

#ifdef REGOLITH_EXE
  // The command: exit 0 and the same text; a file that is not MCAP: exit 2 and one error line with
  // the file and the offset.
  auto run = [](const std::string& args, std::string& out) {
    FILE* p = ::popen((std::string(REGOLITH_EXE) + " log info " + args + " 2>&1").c_str(), "r");
    char buf[4096];
    std::size_t n = 0;
    out.clear();
    while ((n = std::fread(buf, 1, sizeof buf, p)) > 0) out.append(buf, n);
    const int status = ::pclose(p);
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  };
  std::string out;
  EXPECT_EQ(run(cut.string(), out), 0) << out;
  EXPECT_EQ(out, ttext);
  const fs::path png = temp_file("cli_image.mcap");
  {
    std::ofstream o(png, std::ios::binary);
    o << "GIF89a....";
  }
  EXPECT_EQ(run(png.string(), out), 2) << out;
  EXPECT_NE(out.find(png.string() + ": byte 0: not an MCAP file: wrong magic"), std::string::npos) << out;
#endif
}

// Split recordings: every file a complete MCAP file with the same schemas, channels (ids),
// metadata and attachment; the messages spread over the files in time order, none lost or doubled.
TEST(McapSplit, BySizeAndByDurationEveryFileStandsAlone) {
  for (const bool by_size : {true, false}) {
    const fs::path path = temp_file(by_size ? "split_size.mcap" : "split_time.mcap");
    McapWriterOptions o;
    o.chunk_size = 64 * 1024;
    o.compression = Compression::kNone;  // the test payloads compress to almost nothing
    if (by_size)
      o.split_bytes = 150 * 1024;
    else
      o.split_duration_ns = 500'000'000ULL;  // 0.5 s of 2 s
    McapWriter w(path, o);
    const auto js = w.add_schema("sensor_msgs/msg/JointState", "ros2msg", std::string(kJointStateMsg));
    const auto joints = w.add_channel(js, "/rover1/joint_states", "cdr");
    const auto cam = w.add_channel(js, "/rover1/camera/front", "cdr");
    w.add_metadata("regolith", {{"deployment", "mock_rover"}});
    const std::string yaml = "rate_groups: []\n";
    w.add_attachment("deployment.yaml", "application/yaml", 5, 4,
                     std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(yaml.data()), yaml.size()));
    std::uint64_t written = 0;
    for (std::uint32_t t = 0; t < 2000; ++t) {  // 2 s in 1 ms steps
      const std::uint64_t ns = 1'000'000'000ULL + t * 1'000'000ULL;
      if (t % 10 == 0) w.write(joints, t, ns, ns, payload(joints, t, 120)), ++written;
      if (t % 100 == 0) w.write(cam, t, ns, ns, payload(cam, t, 20000)), ++written;
    }
    w.close();
    const auto files = w.files();
    ASSERT_GE(files.size(), 3U) << "by_size " << by_size;
    EXPECT_EQ(files[0], path);
    EXPECT_EQ(files[1].filename().string(), path.stem().string() + "_001.mcap");
    EXPECT_EQ(mcap_split_path(path, 12).filename().string(), path.stem().string() + "_012.mcap");
    std::uint64_t total = 0, bytes = 0, last_end = 0;
    for (std::size_t k = 0; k < files.size(); ++k) {
      McapReader r(files[k]);
      const McapFileInfo& info = r.info();
      EXPECT_TRUE(info.from_summary) << files[k];
      EXPECT_FALSE(info.truncated) << files[k];
      EXPECT_TRUE(info.problems.empty()) << files[k];
      ASSERT_EQ(info.channels.size(), 2U) << files[k];
      EXPECT_EQ(info.channels.at(joints).topic, "/rover1/joint_states");
      EXPECT_EQ(info.channels.at(cam).topic, "/rover1/camera/front");
      ASSERT_EQ(info.attachments.size(), 1U) << files[k];
      EXPECT_EQ(info.attachments[0].name, "deployment.yaml");
      ASSERT_EQ(info.metadata.size(), 1U);
      EXPECT_GT(info.message_count, 0U);
      if (k > 0) {
        EXPECT_GT(info.message_start_time, last_end) << "file " << k << " overlaps the one before";
      }
      last_end = info.message_end_time;
      if (by_size && k + 1 < files.size()) {
        // closed at the first message that found it at the limit: at most a chunk beyond it
        EXPECT_GE(info.file_size, o.split_bytes - o.chunk_size - 30000) << files[k];
        EXPECT_LE(info.file_size, o.split_bytes + o.chunk_size + 30000) << files[k];
      }
      if (!by_size) {
        EXPECT_LT(info.message_end_time - info.message_start_time, o.split_duration_ns) << files[k];
      }
      const auto msgs = read_messages(r);
      EXPECT_EQ(msgs.size(), info.message_count);
      total += info.message_count;
      bytes += info.file_size;
    }
    EXPECT_EQ(total, written);
    EXPECT_EQ(w.stats().messages, written);
    EXPECT_EQ(w.stats().file_bytes, bytes);
  }
  McapWriterOptions bad;
  bad.split_bytes = 100;
  EXPECT_THROW(McapWriter(temp_file("bad_split.mcap"), bad), regolith::FieldError);
}
