#include <array>
#include <cmath>
#include <cstdio>
#include <limits>

#include <gtest/gtest.h>

#include "mock_test_util.hpp"

namespace regolith::mocks::test {
namespace {

constexpr double kTol = 1e-9;

TEST(ScriptedEncoders, ConstantSpeedOnTheSampleGrid) {
  Fixture fx;
  auto enc = fx.encoders(
      "backend: scripted\nwheels: [fl, fr]\nsample_rate_hz: 100\nspeed_rad_s: [1.0, -2.0]\ninitial_angle_rad: 0.5\n");
  ASSERT_EQ(enc->wheel_count(), 2u);
  EXPECT_EQ(enc->wheel_names()[1], "fr");
  hal::AngleSample s;
  const TimeNs t0 = fx.clock.now();
  EXPECT_FALSE(enc->latest(0, t0, s)) << "not started";
  enc->start();
  EXPECT_FALSE(enc->latest(0, t0 - 1, s));
  ASSERT_TRUE(enc->latest(0, t0 + 123'400'000, s));  // 123.4 ms -> sample at 120 ms
  EXPECT_EQ(s.stamp, t0 + 120 * kNsPerMs);
  EXPECT_NEAR(s.angle, 0.5 + 0.12, kTol);
  ASSERT_TRUE(enc->latest(1, t0 + 123'400'000, s));
  EXPECT_NEAR(s.angle, 0.5 - 0.24, kTol);
  fx.clock.set(t0 + 200 * kNsPerMs);
  double a = 0;
  ASSERT_TRUE(enc->angle_at(1, t0 + 115 * kNsPerMs, a));
  EXPECT_NEAR(a, 0.5 - 2.0 * 0.115, kTol);
  ASSERT_TRUE(enc->angle_at(0, t0 + 230 * kNsPerMs, a));  // extrapolated 30 ms (<= 50 ms)
  EXPECT_NEAR(a, 0.5 + 0.23, kTol);
  EXPECT_FALSE(enc->angle_at(0, t0 + 260 * kNsPerMs, a)) << "beyond max_extrapolation_ms";
  EXPECT_FALSE(enc->angle_at(0, t0 - kNsPerMs, a)) << "before the first sample";
  double v = 0;
  ASSERT_TRUE(enc->velocity(1, t0 + 200 * kNsPerMs, v));
  EXPECT_NEAR(v, -2.0, 1e-6);
  const auto st = enc->stats();
  EXPECT_EQ(st.samples, 2u * 21u);
  EXPECT_EQ(st.state, hal::DeviceState::kStreaming);
  EXPECT_FALSE(enc->stale(0, t0 + 200 * kNsPerMs, 5 * kNsPerMs));
}

TEST(ScriptedEncoders, ParameterErrors) {
  Fixture fx;
  std::string msg = config_error([&] { fx.encoders("backend: scripted\nwheels: [a, b]\nspeed_rad_s: [1, 2, 3]\n"); });
  EXPECT_NE(msg.find("speed_rad_s: has 3 values for 2 wheels"), std::string::npos) << msg;
  msg = config_error([&] { fx.encoders("backend: scripted\nspeed_rad_s: 1\n"); });
  EXPECT_NE(msg.find("wheels"), std::string::npos) << msg;
  fx.dir.write("p.csv", "time_s,a\n0,0\n1,1\n");
  msg = config_error([&] { fx.encoders("backend: scripted\nprofile_csv: p.csv\nspeed_rad_s: 1\n"); });
  EXPECT_NE(msg.find("not both"), std::string::npos) << msg;
}

TEST(ScriptedEncoders, CsvProfileInterpolatesAndLoops) {
  Fixture fx;
  fx.dir.write("profiles/p.csv", "# a comment\ntime_s, left, right\n0, 0, 0\n1.0, 1.0, 2.0\n2.0, 1.0, 4.0\n");
  auto enc = fx.encoders("backend: scripted\nprofile_csv: profiles/p.csv\nsample_rate_hz: 50\n");
  ASSERT_EQ(enc->wheel_count(), 2u);
  EXPECT_EQ(enc->wheel_names()[0], "left");
  auto loop = fx.encoders("backend: scripted\nprofile_csv: profiles/p.csv\nwheels: [right]\nloop: true\n");
  ASSERT_EQ(loop->wheel_count(), 1u);
  enc->start();
  loop->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  ASSERT_TRUE(enc->latest(0, t0 + 500 * kNsPerMs, s));
  EXPECT_NEAR(s.angle, 0.5, kTol);
  ASSERT_TRUE(enc->latest(1, t0 + 1500 * kNsPerMs, s));
  EXPECT_NEAR(s.angle, 3.0, kTol);
  ASSERT_TRUE(enc->latest(1, t0 + 3 * kNsPerSec, s));  // held after the end
  EXPECT_NEAR(s.angle, 4.0, kTol);
  ASSERT_TRUE(loop->latest(0, t0 + 2500 * kNsPerMs, s));  // second pass: 4 + profile(0.5) = 5
  EXPECT_NEAR(s.angle, 5.0, kTol);
  ASSERT_TRUE(loop->latest(0, t0 + 5 * kNsPerSec, s));  // third pass, t = 1: 8 + 2
  EXPECT_NEAR(s.angle, 10.0, kTol);
}

TEST(ScriptedEncoders, MalformedCsvNamesFileAndLine) {
  Fixture fx;
  auto err = [&](const std::string& csv, const std::string& extra = "") {
    fx.dir.write("bad.csv", csv);
    return config_error([&] { fx.encoders("backend: scripted\nprofile_csv: bad.csv\n" + extra); });
  };
  std::string msg = err("time_s,a,b\n0,0,0\n0.1,abc,2\n");
  EXPECT_NE(msg.find("bad.csv:3: column 'a': 'abc' is not a finite number"), std::string::npos) << msg;
  msg = err("time_s,a,b\n0,0,0\n\n0.1,1\n");
  EXPECT_NE(msg.find("bad.csv:4: expected 3 values, got 2"), std::string::npos) << msg;
  msg = err("time_s,a\n0,0\n0.5,1\n0.5,2\n");
  EXPECT_NE(msg.find("bad.csv:4: time_s 0.5 is not after"), std::string::npos) << msg;
  msg = err("t,a\n0,0\n");
  EXPECT_NE(msg.find("bad.csv:1: header must be"), std::string::npos) << msg;
  msg = err("time_s,a\n0,0\n", "wheels: [a, c]\n");
  EXPECT_NE(msg.find("bad.csv:1: no column for wheel 'c'"), std::string::npos) << msg;
  msg = err("time_s,a\n0,nan\n");
  EXPECT_NE(msg.find("bad.csv:2:"), std::string::npos) << msg;
  msg = config_error([&] { fx.encoders("backend: scripted\nprofile_csv: missing.csv\n"); });
  EXPECT_NE(msg.find("missing.csv: cannot open"), std::string::npos) << msg;
}

TEST(ScriptedEncoders, DeterministicNoise) {
  Fixture fx;
  const std::string base = "backend: scripted\nwheels: [w]\nspeed_rad_s: 2\nsample_rate_hz: 1000\nnoise_rad: 0.01\n";
  auto a = fx.encoders(base + "seed: 3\n");
  auto b = fx.encoders(base + "seed: 3\n");
  auto c = fx.encoders(base + "seed: 4\n");
  a->start();
  b->start();
  c->start();
  const TimeNs t0 = fx.clock.now();
  double sum = 0, sum2 = 0;
  int differ = 0;
  const int n = 4000;
  for (int k = 0; k < n; ++k) {
    hal::AngleSample sa, sb, sc;
    const TimeNs t = t0 + k * kNsPerMs;
    ASSERT_TRUE(a->latest(0, t, sa));
    ASSERT_TRUE(b->latest(0, t, sb));
    ASSERT_TRUE(c->latest(0, t, sc));
    ASSERT_EQ(sa.angle, sb.angle);
    differ += sa.angle != sc.angle;
    const double e = sa.angle - 2.0 * k * 1e-3;
    sum += e;
    sum2 += e * e;
  }
  const double mean = sum / n;
  const double sd = std::sqrt(sum2 / n - mean * mean);
  EXPECT_NEAR(mean, 0.0, 0.001);
  EXPECT_NEAR(sd, 0.01, 0.0007);
  EXPECT_EQ(differ, n);
}

// ---- candump ------------------------------------------------------------------------------------

// A log of two wheels at 100 Hz: "fl" is a 16-bit unsigned little-endian counter in id 0x0CF
// starting at 60000 and rising 1000 counts per frame (wraps at 65536 after frame 5); "fr" is a
// signed 32-bit big-endian counter in extended id 0x18FF0010 falling by 300 per frame. Frames
// on can1 carry nonsense for the interface filter.
constexpr double kScale = 0.001;  // rad / count
std::string make_log(int frames, const std::string& bad_line = "", int bad_at = -1) {
  std::string log;
  for (int i = 0; i < frames; ++i) {
    if (i == bad_at) log += bad_line + "\n";
    char line[128];
    const double t = 1700000000.0 + 0.01 * i;
    const unsigned fl = (60000u + 1000u * static_cast<unsigned>(i)) & 0xFFFFu;
    std::snprintf(line, sizeof line, "(%.6f) can0 0CF#%02X%02X\n", t, fl & 0xFF, fl >> 8);
    log += line;
    const auto fr = static_cast<std::uint32_t>(-300 * i);
    std::snprintf(line, sizeof line, "(%.6f) can0 18FF0010#%08X\n", t + 0.002, fr);
    log += line;
    std::snprintf(line, sizeof line, "(%.6f) can1 0CF#0000\n", t + 0.005);
    log += line;
  }
  return log;
}
const std::string kWheels =
    "wheels:\n"
    "  fl: {id: 0x0CF, length: 2, signed: false, scale: 0.001}\n"
    "  fr: {id: 0x18FF0010, extended: true, length: 4, endian: big, scale: 0.001}\n";

TEST(CandumpEncoders, ReplaysAnglesAcrossTheCounterWrap) {
  Fixture fx;
  fx.dir.write("logs/run.log", make_log(10));
  auto enc = fx.encoders("backend: candump\nfile: logs/run.log\ninterface: can0\n" + kWheels);
  ASSERT_EQ(enc->wheel_count(), 2u);
  EXPECT_EQ(enc->wheel_names()[0], "fl");
  enc->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  for (int i = 0; i < 10; ++i) {
    ASSERT_TRUE(enc->latest(0, t0 + i * 10 * kNsPerMs + 1 * kNsPerMs, s)) << i;
    EXPECT_EQ(s.stamp, t0 + i * 10 * kNsPerMs);
    EXPECT_NEAR(s.angle, (60000.0 + 1000.0 * i) * kScale, kTol) << "frame " << i;  // 66000+ after the wrap
    ASSERT_TRUE(enc->latest(1, t0 + i * 10 * kNsPerMs + 3 * kNsPerMs, s));
    EXPECT_EQ(s.stamp, t0 + i * 10 * kNsPerMs + 2 * kNsPerMs);
    EXPECT_NEAR(s.angle, -300.0 * i * kScale, kTol);
  }
  EXPECT_FALSE(enc->latest(1, t0 + kNsPerMs, s)) << "fr's first frame is at 2 ms";
  fx.clock.set(t0 + 95 * kNsPerMs);
  double a = 0;
  ASSERT_TRUE(enc->angle_at(0, t0 + 55 * kNsPerMs, a));  // between 65000 and 66000 counts
  EXPECT_NEAR(a, 65.5, kTol);
  EXPECT_EQ(enc->stats().samples, 20u);
  EXPECT_EQ(enc->stats().rejected, 0u);
  // After the log ends (no loop) the newest sample stays the last one and goes stale.
  EXPECT_TRUE(enc->stale(0, t0 + kNsPerSec, 100 * kNsPerMs));
}

TEST(CandumpEncoders, RateScaleAndLoop) {
  Fixture fx;
  fx.dir.write("run.log", make_log(5));
  auto fast = fx.encoders("backend: candump\nfile: run.log\ninterface: can0\nrate_scale: 2\n" + kWheels);
  auto loop = fx.encoders("backend: candump\nfile: run.log\ninterface: can0\nloop: true\n" + kWheels);
  fast->start();
  loop->start();
  const TimeNs t0 = fx.clock.now();
  hal::AngleSample s;
  ASSERT_TRUE(fast->latest(0, t0 + 15 * kNsPerMs, s));  // frames every 5 ms
  EXPECT_EQ(s.stamp, t0 + 15 * kNsPerMs);
  EXPECT_NEAR(s.angle, 63.0, kTol);
  // The can0 log spans 42 ms (fr's last frame) over 10 frames; the loop period adds one mean
  // interval: 42 + 42/9 = 46.666666 ms.
  const TimeNs period = 42 * kNsPerMs + 42 * kNsPerMs / 9;
  ASSERT_TRUE(loop->latest(0, t0 + 46 * kNsPerMs, s));
  EXPECT_EQ(s.stamp, t0 + 40 * kNsPerMs);  // still the last sample of the first pass
  EXPECT_NEAR(s.angle, 64.0, kTol);
  ASSERT_TRUE(loop->latest(0, t0 + 47 * kNsPerMs, s));
  EXPECT_EQ(s.stamp, t0 + period);
  EXPECT_NEAR(s.angle, 60.0 + 4.0, kTol);  // first sample + net rotation of one pass
  ASSERT_TRUE(loop->latest(0, t0 + 2 * period + 25 * kNsPerMs, s));
  EXPECT_EQ(s.stamp, t0 + 2 * period + 20 * kNsPerMs);
  EXPECT_NEAR(s.angle, 62.0 + 8.0, kTol);
  EXPECT_EQ(loop->stats().samples, 1u) << "clock at start: only fl's first frame is due";
}

TEST(CandumpEncoders, GivesTheLogsRawFramesAtTheirReplayTimes) {
  Fixture fx;
  fx.dir.write("run.log", make_log(3));
  auto once = fx.encoders("backend: candump\nfile: run.log\ninterface: can0\n" + kWheels);
  auto loop = fx.encoders("backend: candump\nfile: run.log\ninterface: can0\nloop: true\n" + kWheels);
  EXPECT_TRUE(once->reads_can());
  std::array<hal::CanFrame, 16> out{};
  std::uint64_t cursor = 0, missed = 0;
  EXPECT_EQ(once->can_frames(cursor, fx.clock.now(), out, missed), 0u) << "nothing before start";
  once->start();
  loop->start();
  const TimeNs t0 = fx.clock.now();
  // Frames of can0 at 0, 2, 10, 12, 20, 22 ms: by 11 ms the first three.
  ASSERT_EQ(once->can_frames(cursor, t0 + 11 * kNsPerMs, out, missed), 3u);
  EXPECT_EQ(cursor, 3u);
  EXPECT_EQ(out[0].id, 0x0CFu);
  EXPECT_EQ(out[0].stamp, t0);
  EXPECT_EQ(out[0].len, 2);
  EXPECT_EQ(out[0].data[0], (60000u & 0xFF));
  EXPECT_EQ(out[1].id, 0x18FF0010u);
  EXPECT_TRUE(out[1].extended);
  EXPECT_EQ(out[1].stamp, t0 + 2 * kNsPerMs);
  EXPECT_EQ(out[2].stamp, t0 + 10 * kNsPerMs);
  // The rest, and nothing more once the log has ended (no loop).
  EXPECT_EQ(once->can_frames(cursor, t0 + kNsPerSec, out, missed), 3u);
  EXPECT_EQ(once->can_frames(cursor, t0 + 2 * kNsPerSec, out, missed), 0u);
  EXPECT_EQ(missed, 0u);
  // The decoded samples of the same frames (what a recorder writes beside them).
  std::array<hal::AngleSample, 8> samples{};
  EXPECT_EQ(once->samples_since(0, std::numeric_limits<TimeNs>::min(), t0 + 11 * kNsPerMs, samples), 2u);
  EXPECT_EQ(samples[1].stamp, t0 + 10 * kNsPerMs);
  // Looped: the second pass's frames come one period later, numbered on.
  std::uint64_t lc = 0;
  const TimeNs period = 22 * kNsPerMs + 22 * kNsPerMs / 5;
  ASSERT_EQ(loop->can_frames(lc, t0 + period + 5 * kNsPerMs, out, missed), 8u);
  EXPECT_EQ(out[6].stamp, t0 + period);
  EXPECT_EQ(out[7].stamp, t0 + period + 2 * kNsPerMs);
  EXPECT_EQ(lc, 8u);
}

TEST(CandumpEncoders, MalformedLineNamesFileAndLine) {
  Fixture fx;
  fx.dir.write("bad.log", make_log(4, "(1700000000.020000) can0 0CF#1A2", 2));  // line 7
  const std::string yaml = "backend: candump\nfile: bad.log\n" + kWheels;
  const std::string msg = config_error([&] { fx.encoders(yaml); });
  EXPECT_NE(msg.find("bad.log:7: data '1A2' has an odd number of hex digits"), std::string::npos) << msg;
  auto enc = fx.encoders(yaml + "skip_bad_lines: true\ninterface: can0\n");
  EXPECT_EQ(enc->stats().rejected, 1u);
  enc->start();
  hal::AngleSample s;
  ASSERT_TRUE(enc->latest(0, fx.clock.now() + 30 * kNsPerMs, s));
  EXPECT_NEAR(s.angle, 63.0, kTol);
  fx.dir.write("bad2.log", "garbage\n");
  const std::string msg2 = config_error([&] { fx.encoders("backend: candump\nfile: bad2.log\n" + kWheels); });
  EXPECT_NE(msg2.find("bad2.log:1: expected '(seconds.micros)'"), std::string::npos) << msg2;
}

TEST(CandumpEncoders, ConfigurationErrors) {
  Fixture fx;
  fx.dir.write("run.log", make_log(3));
  std::string msg = config_error(
      [&] { fx.encoders("backend: candump\nfile: run.log\nwheels:\n  fl: {id: 0x0CF, byte_ofset: 1}\n"); });
  EXPECT_NE(msg.find("did you mean 'byte_offset'"), std::string::npos) << msg;
  msg = config_error([&] { fx.encoders("backend: candump\nfile: run.log\nwheels:\n  fl: {id: 0x123}\n"); });
  EXPECT_NE(msg.find("no frame with CAN id 123"), std::string::npos) << msg;
  msg = config_error([&] { fx.encoders("backend: candump\nfile: nope.log\n" + kWheels); });
  EXPECT_NE(msg.find("cannot open candump log"), std::string::npos) << msg;
  msg = config_error([&] { fx.encoders("backend: candump\nfile: run.log\ninterface: vcan9\n" + kWheels); });
  EXPECT_NE(msg.find("has no CAN frames on vcan9"), std::string::npos) << msg;
}

}  // namespace
}  // namespace regolith::mocks::test
