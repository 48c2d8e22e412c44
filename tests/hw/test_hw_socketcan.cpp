// Driver tests of the SocketCAN backend on vcan0 with can-utils' cansend (label hw; skipped when
// there is no vcan0).
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include "hw_util.hpp"
#include "regolith/hal/plausible_encoders.hpp"
#include "regolith/hal_socketcan/socketcan.hpp"

using namespace regolith;
using namespace regolith::hal;
using regolith::hwtest::sh;
using regolith::hwtest::wait_until;

namespace {

bool have_vcan0() {
  for (const auto& i : socketcan::list_can_interfaces())
    if (i.name == "vcan0") return true;
  return false;
}

#define REQUIRE_VCAN0()                                                                                 \
  if (!have_vcan0()) GTEST_SKIP() << "no vcan0 (needs the vcan driver: run tests/hw/run.sh BUILD_DIR)"; \
  if (sh("command -v cansend") != 0) GTEST_SKIP() << "cansend missing (apt-get install can-utils)"

std::unique_ptr<socketcan::SocketCanEncoders> make(const std::string& extra = "") {
  auto p = Params::load_string(R"(interface: vcan0
wheels:
  front_left: {id: 0x101, length: 4, scale: 0.001}
  front_right: {id: 0x101, byte_offset: 4, length: 4, scale: 0.001}
  rear_left: {id: 0x18FF0102, extended: true, length: 2, scale: 0.01}
transducers:
  sinkage: {id: 0x200, length: 2, signed: false, wrap: false, scale: 1.0e-5}
stale_timeout: 0.3
retry_min: 0.02
retry_max: 0.2
)" + extra,
                               "hw_encoders.yaml");
  DeviceContext ctx;
  ctx.id = "wheels";
  return std::make_unique<socketcan::SocketCanEncoders>(socketcan::config_from_params(p), ctx);
}

bool sample(const WheelEncoders& e, std::size_t wheel, AngleSample& s) {
  return e.latest(wheel, monotonic_now(), s);
}

bool wait_angle(const WheelEncoders& e, std::size_t wheel, double value, double timeout = 5.0) {
  return wait_until(
      [&] {
        AngleSample s;
        return sample(e, wheel, s) && std::abs(s.angle - value) < 1e-9;
      },
      timeout);
}

}  // namespace

TEST(HwSocketCan, ListsVcan0) {
  REQUIRE_VCAN0();
  const auto ifs = socketcan::list_can_interfaces();
  const auto it = std::find_if(ifs.begin(), ifs.end(), [](const auto& i) { return i.name == "vcan0"; });
  ASSERT_NE(it, ifs.end());
  EXPECT_TRUE(it->up);
  EXPECT_TRUE(it->virtual_can);
}

TEST(HwSocketCan, CansendFramesBecomeWheelAnglesWithKernelStamps) {
  REQUIRE_VCAN0();
  auto enc = make();
  ASSERT_EQ(enc->wheel_names(), (std::vector<std::string>{"front_left", "front_right", "rear_left", "sinkage"}));
  enc->start();
  const TimeNs before = monotonic_now();
  // front_left = 1000 counts (little endian), front_right = -2000 counts
  ASSERT_EQ(sh("cansend vcan0 101#E803000030F8FFFF"), 0);
  ASSERT_TRUE(wait_angle(*enc, 0, 1.0)) << "front_left never became 1.0 rad";
  ASSERT_TRUE(wait_angle(*enc, 1, -2.0));
  const TimeNs after = monotonic_now();
  AngleSample s;
  ASSERT_TRUE(sample(*enc, 0, s));
  EXPECT_GE(s.stamp, before);
  EXPECT_LE(s.stamp, after);
  EXPECT_TRUE(enc->bus_stats().kernel_timestamps);
  // extended id, 16-bit counter crossing its wrap: 0x7FF0 -> 0x8010 continues upwards
  ASSERT_EQ(sh("cansend vcan0 18FF0102#F07F"), 0);
  ASSERT_TRUE(wait_angle(*enc, 2, 0x7FF0 * 0.01));
  ASSERT_EQ(sh("cansend vcan0 18FF0102#1080"), 0);
  ASSERT_TRUE(wait_angle(*enc, 2, (0x8010 - 0x10000 + 0x10000) * 0.01)) << "wrap not unwrapped";
  // bench transducer: unsigned 12345 counts * 1e-5 m
  ASSERT_EQ(sh("cansend vcan0 200#3930"), 0);
  ASSERT_TRUE(wait_angle(*enc, 3, 0.12345));
  double a = 0;
  ASSERT_TRUE(enc->angle_at(0, s.stamp, a));
  EXPECT_DOUBLE_EQ(a, 1.0);
  const EncoderStats st = enc->stats();
  EXPECT_EQ(st.samples, 5u);
  EXPECT_EQ(st.rejected, 0u);
  EXPECT_EQ(st.state, DeviceState::kStreaming);
  enc->stop();
  EXPECT_EQ(enc->stats().state, DeviceState::kStopped);
}

TEST(HwSocketCan, KernelFiltersDropOtherIdsAndShortFramesAreCounted) {
  REQUIRE_VCAN0();
  auto enc = make();
  enc->start();
  for (const char* f : {"102#01020304", "7FF#00", "18FF0103#0102", "201#1122", "101#R"})
    ASSERT_EQ(sh(std::string("cansend vcan0 ") + f), 0);
  ASSERT_EQ(sh("cansend vcan0 101#0A000000F6FFFFFF"), 0);  // 0.010, -0.010
  ASSERT_TRUE(wait_angle(*enc, 0, 0.010));
  ASSERT_EQ(sh("cansend vcan0 101#0102"), 0);  // DLC 2: too short for both wheels
  ASSERT_TRUE(wait_until([&] { return enc->bus_stats().short_frames >= 1; }, 5.0));
  const auto b = enc->bus_stats();
  EXPECT_EQ(b.frames, 2u) << "only the two 0x101 data frames pass the kernel filters";
  EXPECT_EQ(b.unexpected_ids, 0u);
  EXPECT_EQ(b.short_frames, 1u);
  EXPECT_EQ(enc->stats().rejected, 1u);
  EXPECT_NE(b.last_error.find("frame 0x101 has DLC 2"), std::string::npos) << b.last_error;
  AngleSample s;
  ASSERT_TRUE(sample(*enc, 1, s));
  EXPECT_DOUBLE_EQ(s.angle, -0.010) << "the short frame must not change the angles";
  enc->stop();
}

TEST(HwSocketCan, RawFramesAreKeptForRecordersInOrderWithTheirStamps) {
  REQUIRE_VCAN0();
  auto enc = make("frame_history: 4\n");
  ASSERT_TRUE(enc->reads_can());
  enc->start();
  const TimeNs before = monotonic_now();
  for (const char* f : {"101#E803000030F8FFFF", "18FF0102#F07F", "200#3930"})
    ASSERT_EQ(sh(std::string("cansend vcan0 ") + f), 0);
  ASSERT_TRUE(wait_until([&] { return enc->bus_stats().frames >= 3; }, 5.0));
  std::array<CanFrame, 8> out{};
  std::uint64_t cursor = 0, missed = 0;
  ASSERT_EQ(enc->can_frames(cursor, monotonic_now(), out, missed), 3u);
  EXPECT_EQ(out[0].id, 0x101u);
  EXPECT_EQ(out[0].len, 8);
  EXPECT_EQ(out[0].data[1], 0x03);
  EXPECT_EQ(out[1].id, 0x18FF0102u);
  EXPECT_TRUE(out[1].extended);
  EXPECT_EQ(out[2].id, 0x200u);
  EXPECT_GE(out[0].stamp, before);
  EXPECT_LE(out[0].stamp, out[1].stamp);
  EXPECT_LE(out[2].stamp, monotonic_now());
  // Six more into a history of 4: the two oldest of them are missed.
  for (int i = 0; i < 6; ++i) ASSERT_EQ(sh("cansend vcan0 200#0" + std::to_string(i) + "00"), 0);
  ASSERT_TRUE(wait_until([&] { return enc->bus_stats().frames >= 9; }, 5.0));
  ASSERT_EQ(enc->can_frames(cursor, monotonic_now(), out, missed), 4u);
  EXPECT_EQ(missed, 2u);
  EXPECT_EQ(out[0].data[0], 0x02);
  EXPECT_EQ(cursor, 9u);
  enc->stop();
}

// The bus at full load of garbage (issue 20): random payloads on front_left's id 0x101 as fast as
// cangen sends them, beside random ids and payloads every 0.2 ms, while rear_left (an id the floods
// do not touch) receives eight values by cansend. The device reads through the plausibility check as
// in every deployment. What must hold on any machine: the flood reaches the backend, the check
// rejects the garbage angles, rear_left never shows a value that was not sent, a lost rear_left
// value is only possible when the kernel counted receive-queue overflows, and the bus reads as
// before once the flood ends. Whether the reader keeps up is a matter of the machine's speed (a
// timing, not a pass/fail property); the test prints what it saw. Measured in this project's TCG VM
// (cangen unpaced, ~8000-14000 frames/s: more than a 1 Mbit/s bus carries): reading one frame per
// recvmsg, 15177 overflows of 57601 frames (4329 of 16000 with the kernel's default 208 KiB queue);
// reading batches of 32 per recvmmsg, 0 overflows ("28438 frames passed the kernel filters ...
// rear_left decoded 8 of 8"), also with a single vCPU (23963 frames, 0 overflows).
TEST(HwSocketCan, AGarbageFloodIsCountedWhileAnUntouchedWheelKeepsItsValues) {
  REQUIRE_VCAN0();
  if (sh("command -v cangen") != 0) GTEST_SKIP() << "cangen missing (apt-get install can-utils)";
  auto inner = make();
  socketcan::SocketCanEncoders* raw = inner.get();
  PlausibleEncoders enc(std::move(inner), {});
  enc.start();
  EXPECT_GE(raw->bus_stats().receive_buffer_bytes, 1024u * 1024u) << "receive_buffer_kb (1 MiB) was not granted";
  const std::uint64_t frames0 = raw->bus_stats().frames;
  // Both floods run until stopped below (timeout 30 only guards against a test that dies first;
  // timeout passes the TERM on to cangen).
  ASSERT_EQ(sh("(timeout 30 cangen vcan0 -g 0 -I 101 -L 8 -D r >/dev/null 2>&1 & echo $! > /tmp/regolith_flood.pid)"),
            0);
  ASSERT_EQ(
      sh("(timeout 30 cangen vcan0 -g 0.2 -I r -L r -D r -e >/dev/null 2>&1 & echo $! >> /tmp/regolith_flood.pid)"), 0);
  ASSERT_TRUE(wait_until([&] { return raw->bus_stats().frames > frames0 + 1000; }, 10.0))
      << "the flood never reached the backend";
  constexpr int kSent = 8;
  int checked = 0;
  bool foreign = false;
  for (int k = 1; k <= kSent; ++k) {
    // rear_left: 16-bit counter k x 10 (0.01 rad per count), sent by cansend amid the flood
    char cmd[64];
    const unsigned v = static_cast<unsigned>(k * 10) & 0xFFFFu;
    std::snprintf(cmd, sizeof cmd, "cansend vcan0 18FF0102#%02X%02X", v & 0xFF, v >> 8);
    ASSERT_EQ(sh(cmd), 0);
    if (wait_angle(enc, 2, k * 10 * 0.01, 1.0)) ++checked;
    AngleSample s;
    if (enc.latest(2, monotonic_now(), s)) {
      const double counts = s.angle / 0.01;
      foreign |= std::abs(counts - std::round(counts / 10) * 10) > 1e-6 || counts < 10 || counts > k * 10 + 1e-6;
    }
    if (enc.latest(0, monotonic_now(), s)) {
      EXPECT_TRUE(std::isfinite(s.angle));  // what a rate group reads
    }
  }
  const std::uint64_t during = raw->bus_stats().frames - frames0;
  ASSERT_EQ(sh("kill $(cat /tmp/regolith_flood.pid); sleep 0.5"), 0);  // the floods end
  const socketcan::BusStats b = raw->bus_stats();
  std::printf(
      "flood: %llu frames passed the kernel filters, %llu garbage samples rejected, %llu rx overflows "
      "(receive queue %llu bytes), rear_left decoded %d of %d values\n",
      static_cast<unsigned long long>(b.frames - frames0), static_cast<unsigned long long>(enc.stats().rejected),
      static_cast<unsigned long long>(b.rx_overflows), static_cast<unsigned long long>(b.receive_buffer_bytes), checked,
      kSent);
  EXPECT_GT(during, 2000u) << "the flood did not last through the eight rear_left values";
  EXPECT_GT(enc.stats().rejected, 0u) << "random payloads on 0x101 are implausible wheel angles";
  EXPECT_EQ(enc.stats().lost, b.rx_overflows) << "lost frames reach the health monitor through the plausibility check";
  EXPECT_FALSE(foreign) << "rear_left showed a value nobody sent";
  EXPECT_TRUE(checked == kSent || b.rx_overflows > 0)
      << "rear_left lost " << kSent - checked << " values and no receive-queue overflow was counted";
  // The bus is read as before once the flood is over: the next count (90, a plausible 0.1 rad step
  // from the last value sent; a far jump would be rejected by the rate check when it comes fast).
  ASSERT_EQ(sh("cansend vcan0 18FF0102#5A00"), 0);
  EXPECT_TRUE(wait_angle(enc, 2, 90 * 0.01, 2.0)) << "rear_left did not read 90 counts after the flood";
  EXPECT_EQ(raw->stats().state, DeviceState::kStreaming);
  enc.stop();
}

TEST(HwSocketCan, StaleWheelsAreFlaggedAndRecover) {
  REQUIRE_VCAN0();
  auto enc = make();
  enc->start();
  ASSERT_EQ(sh("cansend vcan0 101#0100000001000000"), 0);
  ASSERT_TRUE(wait_angle(*enc, 0, 0.001));
  EXPECT_FALSE(enc->stale_flag(0));
  ASSERT_TRUE(wait_until([&] { return enc->stale_flag(0); }, 5.0)) << "no stale flag after 0.3 s without data";
  EXPECT_GE(enc->stats().stale_events, 4u) << "every channel went stale (two never had data)";
  ASSERT_EQ(sh("cansend vcan0 101#0200000002000000"), 0);
  ASSERT_TRUE(wait_angle(*enc, 0, 0.002));
  EXPECT_FALSE(enc->stale_flag(0));
  AngleSample s;
  ASSERT_TRUE(sample(*enc, 0, s));
  EXPECT_FALSE(enc->stale(0, s.stamp + 100 * kNsPerMs, 300 * kNsPerMs));
  EXPECT_TRUE(enc->stale(0, s.stamp + 400 * kNsPerMs, 300 * kNsPerMs));
  enc->stop();
}

TEST(HwSocketCan, SurvivesInterfaceDownUpAndRemoval) {
  REQUIRE_VCAN0();
  if (sh("ip link set vcan0 up") != 0) GTEST_SKIP() << "cannot change vcan0 (needs CAP_NET_ADMIN)";
  auto enc = make();
  enc->start();
  ASSERT_EQ(sh("cansend vcan0 101#0100000000000000"), 0);
  ASSERT_TRUE(wait_angle(*enc, 0, 0.001));
  ASSERT_EQ(sh("ip link set vcan0 down"), 0);
  ASSERT_TRUE(wait_until([&] { return enc->stats().state == DeviceState::kFaulted; }, 5.0)) << "down not detected";
  EXPECT_EQ(enc->bus_stats().interface_down, 1u);
  EXPECT_NE(enc->bus_stats().last_error.find("interface 'vcan0' went down"), std::string::npos);
  ASSERT_EQ(sh("ip link set vcan0 up"), 0);
  ASSERT_TRUE(wait_until([&] { return enc->stats().state == DeviceState::kStreaming; }, 5.0)) << "up not detected";
  ASSERT_EQ(sh("cansend vcan0 101#0300000000000000"), 0);
  ASSERT_TRUE(wait_angle(*enc, 0, 0.003)) << "no data after down/up";
  // interface deleted and re-created: the socket is re-opened on the new interface
  ASSERT_EQ(sh("ip link del vcan0"), 0);
  ASSERT_TRUE(wait_until([&] { return enc->stats().state != DeviceState::kStreaming; }, 5.0));
  ASSERT_EQ(sh("ip link add dev vcan0 type vcan && ip link set vcan0 up"), 0);
  ASSERT_TRUE(wait_until([&] { return enc->stats().state == DeviceState::kStreaming; }, 5.0))
      << enc->bus_stats().last_error;
  ASSERT_TRUE(wait_until(
      [&] {
        sh("cansend vcan0 101#0400000000000000");
        AngleSample s;
        return sample(*enc, 0, s) && std::abs(s.angle - 0.004) < 1e-9;
      },
      5.0))
      << "no data after re-creation";
  EXPECT_GE(enc->stats().faults, 2u);
  enc->stop();
}

TEST(HwSocketCan, ErrorFramesAreDecodedIntoCounters) {
  REQUIRE_VCAN0();
  auto enc = make();
  enc->start();
  // vcan has no controller, but an error frame sent by a raw socket loops back to error filters
  ASSERT_EQ(sh("cansend vcan0 20000040#0000000000000000"), 0);  // bus-off
  ASSERT_TRUE(wait_until([&] { return enc->bus_stats().bus_off >= 1; }, 5.0)) << "bus-off not counted";
  EXPECT_EQ(enc->stats().state, DeviceState::kFaulted);
  ASSERT_EQ(sh("cansend vcan0 20000004#0020000000000000"), 0);  // controller: tx error passive
  ASSERT_EQ(sh("cansend vcan0 20000002#0500000000000000"), 0);  // lost arbitration at bit 5
  ASSERT_EQ(sh("cansend vcan0 20000100#0000000000000000"), 0);  // controller restarted
  ASSERT_TRUE(wait_until([&] { return enc->bus_stats().restarts >= 1; }, 5.0));
  const auto b = enc->bus_stats();
  EXPECT_EQ(b.error_frames, 4u);
  EXPECT_EQ(b.error_passive, 1u);
  EXPECT_EQ(b.lost_arbitration, 1u);
  EXPECT_EQ(b.controller_problems, 1u);
  EXPECT_EQ(enc->stats().state, DeviceState::kStreaming) << "restart ends the bus-off fault";
  EXPECT_EQ(enc->stats().faults, 1u);
  enc->stop();
}

TEST(HwSocketCan, CommandFramesAreSentOnlyWhenEnabled) {
  REQUIRE_VCAN0();
  auto disabled = make();
  const std::uint8_t payload[3] = {0xAA, 0xBB, 0xCC};
  EXPECT_THROW(disabled->send(payload, 3), std::logic_error);
  auto enc = make("command: {enabled: true, id: 0x300}\n");
  // a listener socket on vcan0 for id 0x300
  const int fd = ::socket(PF_CAN, SOCK_RAW, CAN_RAW);
  ASSERT_GE(fd, 0);
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(if_nametoindex("vcan0"));
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
  timeval tv{2, 0};
  setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ASSERT_TRUE(enc->send(payload, 3));
  can_frame f{};
  ASSERT_EQ(::read(fd, &f, sizeof f), static_cast<ssize_t>(sizeof f));
  ::close(fd);
  EXPECT_EQ(f.can_id, 0x300u);
  EXPECT_EQ(f.len, 3u);
  EXPECT_EQ(f.data[2], 0xCC);
  EXPECT_EQ(enc->bus_stats().tx_frames, 1u);
}

TEST(HwSocketCan, DownInterfaceIsAStartupError) {
  REQUIRE_VCAN0();
  if (sh("ip link set vcan0 down") != 0) GTEST_SKIP() << "cannot change vcan0 (needs CAP_NET_ADMIN)";
  std::string msg;
  try {
    make();
  } catch (const DeviceUnavailableError& e) {  // may come up later: `regolith run` exits 3 (restartable)
    EXPECT_EQ(e.field(), "interface");
    msg = e.what();
  }
  sh("ip link set vcan0 up");
  EXPECT_NE(msg.find("socketcan 'wheels': interface 'vcan0' is down (bring it up: ip link set vcan0 up)"),
            std::string::npos)
      << msg;
}
