// The shared CAN decoder and the candump log parser, table-driven.
#include <array>
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>

#include "regolith/hal/can.hpp"

using namespace regolith;
using namespace regolith::hal;

namespace {

CanFrame frame(std::uint32_t id, std::vector<std::uint8_t> bytes, bool ext = false) {
  CanFrame f;
  f.id = id;
  f.extended = ext;
  f.len = static_cast<std::uint8_t>(bytes.size());
  std::copy(bytes.begin(), bytes.end(), f.data.begin());
  return f;
}

CanSignal sig(int offset, int len, bool big, bool is_signed, double scale = 1.0, double off = 0.0, bool wrap = false,
              std::uint32_t id = 0x10, bool ext = false) {
  CanSignal s;
  s.name = "w";
  s.id = id;
  s.extended = ext;
  s.byte_offset = offset;
  s.length = len;
  s.big_endian = big;
  s.is_signed = is_signed;
  s.scale = scale;
  s.offset = off;
  s.wrap = wrap;
  return s;
}

struct DecodeCase {
  const char* what;
  CanSignal sig;
  std::vector<std::uint8_t> bytes;
  double expect;
};

}  // namespace

TEST(CanDecoder, LayoutsTable) {
  const double tick = 2 * std::numbers::pi / 4096;
  const std::vector<DecodeCase> cases = {
      {"u16 little endian", sig(0, 2, false, false), {0x34, 0x12}, 0x1234},
      {"u16 big endian", sig(0, 2, true, false), {0x12, 0x34}, 0x1234},
      {"i16 negative LE", sig(0, 2, false, true), {0xFE, 0xFF}, -2},
      {"i32 negative BE", sig(0, 4, true, true), {0xFF, 0xFF, 0xFF, 0x9C}, -100},
      {"offset 3, 1 byte", sig(3, 1, false, false), {0, 0, 0, 0xAB}, 0xAB},
      {"scale to rad", sig(0, 2, false, false, tick), {0x00, 0x04}, 1024 * tick},
      {"scale and offset", sig(0, 1, false, true, 0.5, 1.0), {0x04}, 3.0},
      {"i24 BE", sig(1, 3, true, true), {0, 0x80, 0x00, 0x00}, -8388608},
      {"u64 LE", sig(0, 8, false, false), {1, 0, 0, 0, 0, 0, 0, 0}, 1},
  };
  for (const auto& c : cases) {
    CanDecoder d({c.sig});
    double got = NAN;
    const int n = d.decode(frame(0x10, c.bytes), [&](std::size_t, double v) { got = v; });
    EXPECT_EQ(n, 1) << c.what;
    EXPECT_DOUBLE_EQ(got, c.expect) << c.what;
  }
}

TEST(CanDecoder, IdsFilteringAndShortFrames) {
  CanDecoder d({sig(0, 2, false, false, 1.0, 0.0, false, 0x100), sig(2, 2, false, false, 1.0, 0.0, false, 0x100),
                sig(0, 1, false, false, 1.0, 0.0, false, 0x18FF0001, true)});
  std::vector<std::pair<std::size_t, double>> got;
  auto sink = [&](std::size_t i, double v) { got.emplace_back(i, v); };
  EXPECT_EQ(d.decode(frame(0x100, {1, 0, 2, 0}), sink), 2);        // two signals in one frame
  EXPECT_EQ(d.decode(frame(0x101, {1, 0, 2, 0}), sink), 0);        // other id
  EXPECT_EQ(d.decode(frame(0x100, {1, 0, 2, 0}, true), sink), 0);  // same number, extended: other id
  EXPECT_EQ(d.decode(frame(0x18FF0001, {7}, true), sink), 1);
  EXPECT_EQ(d.decode(frame(0x100, {1, 0, 2}), sink), 1);  // b does not fit: short
  EXPECT_EQ(d.short_frames(), 1u);
  CanFrame err = frame(0x100, {1, 0, 2, 0});
  err.error = true;
  EXPECT_EQ(d.decode(err, sink), 0);
  ASSERT_EQ(got.size(), 4u);
  EXPECT_EQ(got[1], (std::pair<std::size_t, double>{1, 2.0}));
  EXPECT_EQ(got[2], (std::pair<std::size_t, double>{2, 7.0}));
  EXPECT_EQ(d.ids().size(), 2u);
}

TEST(CanDecoder, UnwrapsCountersAcrossTheLimitBothWays) {
  CanDecoder d({sig(0, 1, false, false, 1.0, 0.0, true, 0x20)});
  std::vector<double> got;
  for (int raw : {250, 254, 3, 10, 250, 5}) {
    d.decode(frame(0x20, {static_cast<std::uint8_t>(raw)}), [&](std::size_t, double v) { got.push_back(v); });
  }
  // 250 -> 254 -> (wrap) 259 -> 266 -> (wrap back) 250 -> (wrap) 261
  EXPECT_EQ(got, (std::vector<double>{250, 254, 259, 266, 250, 261}));
}

struct LineCase {
  const char* line;
  bool ok;
  std::uint32_t id;
  bool ext;
  int len;
  const char* error;
};

TEST(Candump, ParserTable) {
  const std::vector<LineCase> cases = {
      {"(1700000000.123456) can0 0CF#1A2B3C4D", true, 0x0CF, false, 4, ""},
      {"(1700000000.123456) vcan0 18FF0001#0102030405060708", true, 0x18FF0001, true, 8, ""},
      {"(1700000000.123456) can0 123#", true, 0x123, false, 0, ""},
      {"(1700000000.123456) can0 123#R", true, 0x123, false, 0, ""},
      {"(1700000000.123456) can0 123##1AABB", true, 0x123, false, 2, ""},
      {"(1700000000.123456) can0 123#1A2B\r\n", true, 0x123, false, 2, ""},
      {"1700000000.123456 can0 123#00", false, 0, false, 0, "expected '(seconds.micros)' at the start of the line"},
      {"(1700000000.123456 can0 123#00", false, 0, false, 0, "missing ')' after the timestamp"},
      {"(17000x0000.1) can0 123#00", false, 0, false, 0, "bad timestamp '17000x0000.1'"},
      {"(1700000000) can0 123#00", false, 0, false, 0, "bad timestamp '1700000000'"},
      {"(1700000000.1) can0 12345#00", false, 0, false, 0,
       "identifier '12345' must have 3 (standard) or 8 (extended) hex digits"},
      {"(1700000000.1) can0 1G3#00", false, 0, false, 0, "identifier '1G3' is not hexadecimal"},
      {"(1700000000.1) can0 800#00", false, 0, false, 0, "standard identifier exceeds 0x7FF"},
      {"(1700000000.1) can0 123#123", false, 0, false, 0, "data '123' has an odd number of hex digits"},
      {"(1700000000.1) can0 123#0011223344556677AA", false, 0, false, 0, "data has 9 bytes (max 8)"},
      {"(1700000000.1) can0 123#zz", false, 0, false, 0, "data 'zz' is not hexadecimal"},
      {"(1700000000.1) can0 123", false, 0, false, 0, "missing '#' between identifier and data"},
      {"(1700000000.1) can0", false, 0, false, 0, "expected '<interface> <id>#<data>' after the timestamp"},
      {"", false, 0, false, 0, "expected '(seconds.micros)' at the start of the line"},
  };
  for (const auto& c : cases) {
    CanFrame f;
    std::string iface, error;
    double t = 0;
    const bool ok = parse_candump_line(c.line, f, iface, t, error);
    EXPECT_EQ(ok, c.ok) << c.line << " -> " << error;
    if (ok) {
      EXPECT_EQ(f.id, c.id) << c.line;
      EXPECT_EQ(f.extended, c.ext) << c.line;
      EXPECT_EQ(f.len, c.len) << c.line;
      EXPECT_NEAR(t, 1700000000.123456, 1e-6) << c.line;
    } else {
      EXPECT_EQ(error, c.error) << c.line;
    }
  }
  CanFrame f;
  std::string iface, error;
  double t = 0;
  ASSERT_TRUE(parse_candump_line("(1700000000.5) can1 0CF#1A2B3C4D", f, iface, t, error));
  EXPECT_EQ(iface, "can1");
  EXPECT_EQ(f.data[0], 0x1A);
  EXPECT_EQ(f.data[3], 0x4D);
  ASSERT_TRUE(parse_candump_line("(1700000000.5) can1 123#R", f, iface, t, error));
  EXPECT_TRUE(f.remote);
}

TEST(CanSignalParams, ValidatedFromYaml) {
  auto p = Params::load_string("id: 0x7FF\nlength: 2\nendian: big\nscale: 0.001\n", "enc.yaml");
  const CanSignal s = can_signal_from_params(p, "wheel_fl");
  EXPECT_EQ(s.id, 0x7FFu);
  EXPECT_TRUE(s.big_endian);
  EXPECT_DOUBLE_EQ(s.scale, 0.001);
  auto bad = Params::load_string("id: 0x800\n", "enc.yaml");
  try {
    can_signal_from_params(bad, "w");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_STREQ(e.what(), "enc.yaml:1:5: id: value must be <= 2047 (got 2048)");
  }
  auto bad2 = Params::load_string("id: 1\nlength: 9\n", "enc.yaml");
  EXPECT_THROW(can_signal_from_params(bad2, "w"), ConfigError);
}

namespace {

TEST(CanFrameHistory, GivesFramesInOrderAndCountsTheOnesItNoLongerHolds) {
  CanFrameHistory h(4);
  std::array<CanFrame, 3> out{};
  std::uint64_t cursor = 0, missed = 0;
  EXPECT_EQ(h.since(cursor, out, missed), 0u);
  for (std::uint32_t i = 0; i < 3; ++i) {
    CanFrame f;
    f.id = 0x100 + i;
    h.push(f);
  }
  ASSERT_EQ(h.since(cursor, out, missed), 3u);
  EXPECT_EQ(out[0].id, 0x100u);
  EXPECT_EQ(out[2].id, 0x102u);
  EXPECT_EQ(cursor, 3u);
  EXPECT_EQ(h.since(cursor, out, missed), 0u);
  for (std::uint32_t i = 3; i < 10; ++i) {  // 7 more into 4 slots: frames 3..5 are overwritten
    CanFrame f;
    f.id = 0x100 + i;
    h.push(f);
  }
  ASSERT_EQ(h.since(cursor, out, missed), 3u);  // at most out.size()
  EXPECT_EQ(missed, 3u);
  EXPECT_EQ(out[0].id, 0x106u);
  ASSERT_EQ(h.since(cursor, out, missed), 1u);
  EXPECT_EQ(out[0].id, 0x109u);
  EXPECT_EQ(cursor, 10u);
  EXPECT_EQ(h.pushed(), 10u);
}

TEST(Candump, FormattedLinesParseBackToTheSameFrame) {
  const std::vector<std::string> lines = {
      "(1700000000.000100) can0 0CF#1A2B",
      "(1700000000.250000) can0 18FF0010#0102030405060708",
      "(1700000001.000000) wheels 123#R",
      "(1700000001.000001) can0 7FF#",
      "(1700000002.123456) can1 456##0" + std::string(128, 'E'),  // FD, 64 bytes
      "(1700000003.000000) can0 20000004#0000080000000000",       // error frame (controller)
  };
  for (const auto& line : lines) {
    CanFrame f;
    std::string iface, error;
    double t = 0;
    ASSERT_TRUE(parse_candump_line(line, f, iface, t, error)) << line << ": " << error;
    const std::int64_t ns = static_cast<std::int64_t>(std::llround(t * 1e6)) * 1000;
    EXPECT_EQ(format_candump_line(f, iface, ns), line);
  }
  CanFrame f;
  f.id = 0x55;
  f.len = 1;
  f.data[0] = 0xAB;
  EXPECT_EQ(format_candump_line(f, "can0", -1), "(-1.999999) can0 055#AB") << "times before 1970 still format";
}

}  // namespace
