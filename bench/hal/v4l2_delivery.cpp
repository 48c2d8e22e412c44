// Frame delivery of the V4L2 backend against `v4l2-ctl --stream-mmap` on the same device in the
// same run (vivid inside tests/hw/run.sh; any capture node offering YUYV otherwise).
//
//  * latency: kernel capture timestamp (CLOCK_MONOTONIC) -> the moment the consumer has the frame.
//    regolith: a consumer thread polls Camera::latest() every 100 us; v4l2-ctl: its --verbose
//    "ts:" line per dequeued buffer, read from a pipe by this process (stdbuf -o0 when present).
//  * CPU per frame: regolith: process CPU time over a window of N frames with nothing else running
//    in the process; v4l2-ctl: (CPU of a run of N2 frames - CPU of a run of N1 frames) / (N2 - N1),
//    so its start-up cost cancels out.
// Both use 640x480 YUYV, 4 mmap buffers and the rate the backend negotiated. regolith converts
// to bgr8 and to mono8 (two rows); v4l2-ctl discards the data (--stream-to=/dev/null).
// vivid stamps the END of the frame period by default, which lies ahead of the dequeue under load
// (the backend clamps such stamps to its dequeue time, v4l2-ctl prints them raw): for a common
// reference the bench first switches vivid to "Start of Exposure" stamps (timestamp_source=1).
// Exits 0 with a message when there is no V4L2 capture device or no v4l2-ctl.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <benchmark/benchmark.h>

#include "regolith/hal_v4l2/v4l2.hpp"

extern char** environ;
using namespace regolith;
using namespace regolith::hal;

namespace {

constexpr int kWidth = 640, kHeight = 480, kBuffers = 4;
constexpr int kLatencyFrames = 60;
constexpr int kCpuFrames = 90;
constexpr int kPeerShort = 20, kPeerLong = 110;

struct Result {
  std::string name;
  std::vector<double> latency_us;
  double cpu_us_per_frame = NAN;
  double fps = NAN;
  std::uint64_t dropped = 0;
};

struct Stats {
  double p50 = NAN, p99 = NAN, max = NAN;
};
Stats stats_of(std::vector<double> v) {
  if (v.empty()) return {};
  std::sort(v.begin(), v.end());
  auto at = [&](double q) { return v[static_cast<std::size_t>(q * static_cast<double>(v.size() - 1))]; };
  return {at(0.5), at(0.99), v.back()};
}

double process_cpu_s() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + static_cast<double>(ts.tv_nsec) * 1e-9;
}

std::string g_device;  // node under test
double g_rate = 30.0;  // negotiated by the backend, reused for v4l2-ctl
std::vector<Result> g_results;
std::string g_peer_note;

template <class Pred>
bool wait_for(Pred&& pred, double timeout_s, int poll_us) {
  const TimeNs end = monotonic_now() + from_seconds(timeout_s);
  while (!pred()) {
    if (monotonic_now() > end) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(poll_us));
  }
  return true;
}

Result measure_backend(PixelFormat out) {
  v4l2::Config c;
  c.device = g_device;
  c.width = kWidth;
  c.height = kHeight;
  c.fourcc = "YUYV";
  c.output = out;
  c.rate_hz = 30.0;
  c.buffers = kBuffers;
  DeviceContext ctx;
  ctx.id = "bench";
  v4l2::V4l2Camera cam(c, ctx);
  g_rate = cam.format().rate_hz;
  Result r;
  r.name = std::string("regolith v4l2 -> ") + std::string(to_string(out));
  cam.start();
  if (!wait_for([&] { return cam.stats().frames >= 5; }, 15.0, 10000)) {
    std::fprintf(stderr, "v4l2_delivery: no frames from %s within 15 s\n", g_device.c_str());
    cam.stop();
    return r;
  }
  // latency: poll latest() every 100 us
  std::uint64_t last_gen = 0;
  r.latency_us.reserve(kLatencyFrames);
  wait_for(
      [&] {
        FrameLease lease;
        if (cam.latest(monotonic_now(), lease) && lease.generation() != last_gen) {
          const TimeNs now = monotonic_now();
          if (last_gen != 0) r.latency_us.push_back(static_cast<double>(now - lease->capture_time) / 1e3);
          last_gen = lease.generation();
        }
        return static_cast<int>(r.latency_us.size()) >= kLatencyFrames;
      },
      30.0, 100);
  // CPU: the capture thread alone (this thread sleeps 20 ms between counter reads)
  const CameraStats s0 = cam.stats();
  const double cpu0 = process_cpu_s();
  const TimeNs t0 = monotonic_now();
  wait_for([&] { return cam.stats().frames >= s0.frames + kCpuFrames; }, 30.0, 20000);
  const CameraStats s1 = cam.stats();
  const double cpu1 = process_cpu_s();
  const TimeNs t1 = monotonic_now();
  cam.stop();
  const double n = static_cast<double>(s1.frames - s0.frames);
  if (n > 0) {
    r.cpu_us_per_frame = (cpu1 - cpu0) * 1e6 / n;
    r.fps = n / to_seconds(t1 - t0);
  }
  r.dropped = s1.dropped;
  return r;
}

struct ChildRun {
  int exit_code = -1;
  double cpu_s = 0;
  std::vector<double> latency_us;
};

/// Runs v4l2-ctl streaming `count` frames; with `verbose`, reads its per-buffer lines from a pipe
/// and records (arrival time - kernel timestamp).
ChildRun run_v4l2_ctl(int count, bool verbose) {
  std::vector<std::string> args;
  const bool have_stdbuf = access("/usr/bin/stdbuf", X_OK) == 0;
  if (verbose && have_stdbuf) args = {"/usr/bin/stdbuf", "-o0", "-e0"};
  char parm[32];
  std::snprintf(parm, sizeof parm, "%g", g_rate);
  for (const std::string& a :
       {std::string("v4l2-ctl"), std::string("-d"), g_device,
        "--set-fmt-video=width=" + std::to_string(kWidth) + ",height=" + std::to_string(kHeight) + ",pixelformat=YUYV",
        std::string("--set-parm=") + parm, "--stream-mmap=" + std::to_string(kBuffers),
        "--stream-count=" + std::to_string(count), std::string("--stream-to=/dev/null")})
    args.push_back(a);
  if (verbose) args.emplace_back("--verbose");
  int pipefd[2];
  ChildRun out;
  if (pipe(pipefd) != 0) return out;
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_adddup2(&fa, pipefd[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&fa, pipefd[1], STDERR_FILENO);
  posix_spawn_file_actions_addclose(&fa, pipefd[0]);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawnp(&pid, argv[0], &fa, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&fa);
  close(pipefd[1]);
  if (rc != 0) {
    close(pipefd[0]);
    return out;
  }
  // read lines; "... ts: 123.456789 ..." per dequeued buffer
  std::string buf, line;
  char chunk[4096];
  ssize_t n;
  while ((n = read(pipefd[0], chunk, sizeof chunk)) > 0) {
    const TimeNs now = monotonic_now();
    buf.append(chunk, static_cast<std::size_t>(n));
    std::size_t nl;
    while ((nl = buf.find('\n')) != std::string::npos) {
      line = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      const auto p = line.find(" ts: ");
      if (!verbose || p == std::string::npos) continue;
      long long sec = 0, usec = 0;
      if (std::sscanf(line.c_str() + p + 5, "%lld.%6lld", &sec, &usec) == 2) {
        const TimeNs ts = sec * kNsPerSec + usec * 1000;
        out.latency_us.push_back(static_cast<double>(now - ts) / 1e3);
      }
    }
  }
  close(pipefd[0]);
  int status = 0;
  rusage ru{};
  if (wait4(pid, &status, 0, &ru) == pid) {
    out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    out.cpu_s = static_cast<double>(ru.ru_utime.tv_sec + ru.ru_stime.tv_sec) +
                static_cast<double>(ru.ru_utime.tv_usec + ru.ru_stime.tv_usec) * 1e-6;
  }
  if (!out.latency_us.empty()) out.latency_us.erase(out.latency_us.begin());  // first: start-up
  return out;
}

Result measure_peer() {
  Result r;
  r.name = "v4l2-ctl --stream-mmap";
  const ChildRun lat = run_v4l2_ctl(kLatencyFrames + 1, true);
  const ChildRun a = run_v4l2_ctl(kPeerShort, false);
  const TimeNs t0 = monotonic_now();
  const ChildRun b = run_v4l2_ctl(kPeerLong, false);
  const TimeNs t1 = monotonic_now();
  if (lat.exit_code != 0 || a.exit_code != 0 || b.exit_code != 0) {
    g_peer_note = "v4l2-ctl failed (exit " + std::to_string(lat.exit_code) + "/" + std::to_string(a.exit_code) + "/" +
                  std::to_string(b.exit_code) + "; 127 or -1 = not installed: apt-get install v4l-utils)";
    return r;
  }
  r.latency_us = lat.latency_us;
  if (r.latency_us.empty()) g_peer_note = "no 'ts:' lines in v4l2-ctl --verbose output: latency not measured";
  r.cpu_us_per_frame = (b.cpu_s - a.cpu_s) * 1e6 / (kPeerLong - kPeerShort);
  r.fps = kPeerLong / to_seconds(t1 - t0);  // includes start-up: a lower bound
  return r;
}

void report(benchmark::State& state, const Result& r) {
  const Stats s = stats_of(r.latency_us);
  state.counters["lat_p50_us"] = s.p50;
  state.counters["lat_p99_us"] = s.p99;
  state.counters["cpu_us_per_frame"] = r.cpu_us_per_frame;
  g_results.push_back(r);
}

void BM_RegolithV4l2(benchmark::State& state) {
  const PixelFormat out = state.range(0) == 0 ? PixelFormat::kBgr8 : PixelFormat::kMono8;
  for (auto _ : state) report(state, measure_backend(out));
}
void BM_V4l2Ctl(benchmark::State& state) {
  for (auto _ : state) report(state, measure_peer());
}
BENCHMARK(BM_RegolithV4l2)->Arg(0)->Arg(1)->Iterations(1)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_V4l2Ctl)->Iterations(1)->Unit(benchmark::kMillisecond);

std::optional<std::string> pick_device(std::string& what) {
  const auto devs = v4l2::list_v4l2_devices(true);
  for (const auto& d : devs)
    if (d.capture && d.driver == "vivid") {
      what = d.path + " (vivid, " + d.bus_info + ")";
      return d.path;
    }
  for (const auto& d : devs) {
    if (!d.capture) continue;
    for (const auto& f : d.formats)
      if (f.fourcc == "YUYV") {
        what = d.path + " (" + d.driver + ", " + d.card + ")";
        return d.path;
      }
  }
  return std::nullopt;
}

}  // namespace

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  std::string what;
  const auto dev = pick_device(what);
  if (!dev) {
    std::printf(
        "v4l2_delivery: no V4L2 capture device offering YUYV (load vivid, or run "
        "tests/hw/run.sh BUILD_DIR bench/hal/v4l2_delivery): nothing measured\n");
    return 0;
  }
  g_device = *dev;
  if (what.find("vivid") != std::string::npos) {
    const std::string cmd = "v4l2-ctl -d " + g_device + " -c timestamp_source=1 >/dev/null 2>&1";
    const int rc = std::system(cmd.c_str());
    std::printf("vivid timestamp_source=1 (start of exposure): %s\n",
                rc == 0 ? "set" : "FAILED (stamps are end of frame)");
  }
  std::printf("device: %s, %dx%d YUYV, %d buffers\n", what.c_str(), kWidth, kHeight, kBuffers);
  try {
    benchmark::RunSpecifiedBenchmarks();
  } catch (const std::exception& e) {
    std::printf("v4l2_delivery: %s\n", e.what());
    return 1;
  }
  std::printf("\nframe delivery, kernel timestamp -> consumer has the frame (us); CPU per frame (us)\n");
  std::printf("%-28s %7s %9s %9s %9s %10s %7s %8s\n", "who", "frames", "lat_p50", "lat_p99", "lat_max", "cpu/frame",
              "fps", "dropped");
  const Result* peer = nullptr;
  for (const auto& r : g_results) {
    const Stats s = stats_of(r.latency_us);
    std::printf("%-28s %7zu %9.0f %9.0f %9.0f %10.1f %7.1f %8llu\n", r.name.c_str(), r.latency_us.size(), s.p50, s.p99,
                s.max, r.cpu_us_per_frame, r.fps, static_cast<unsigned long long>(r.dropped));
    if (r.name.rfind("v4l2-ctl", 0) == 0) peer = &r;
  }
  if (!g_peer_note.empty()) std::printf("note: %s\n", g_peer_note.c_str());
  if (peer != nullptr) {
    const Stats ps = stats_of(peer->latency_us);
    for (const auto& r : g_results) {
      if (&r == peer) continue;
      const Stats s = stats_of(r.latency_us);
      std::printf("ratio %s / v4l2-ctl: latency p50 %.2f, p99 %.2f, CPU per frame %.2f\n", r.name.c_str(),
                  s.p50 / ps.p50, s.p99 / ps.p99, r.cpu_us_per_frame / peer->cpu_us_per_frame);
    }
  }
  benchmark::Shutdown();
  return 0;
}
