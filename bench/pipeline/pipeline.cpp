// The forward terrain pipeline as it is deployed: a synthetic_terrain camera at 30 Hz feeding sfs
// + sams + traversability in one 30 Hz rate group, DDS on (terrain/rocks, terrain/grid_map). Per
// resolution:
//   1. simulated clock: CPU time per frame of each member (its thread CPU in step), summed;
//   2. real time: slips of the 30 Hz group, and the capture -> receipt latency of terrain/rocks
//      measured by a C++ DDS subscriber in another process (`regolith echo --delay`: receipt
//      ROS time - header stamp, the frame's capture time);
//   3. the peer, same frame, same run, one thread: OpenCV StereoSGBM with 64 disparities, once
//      after each 0.5 s window of (1); sgbm64_ratio is the median of the per-window ratios.
// The last line per resolution is for scripts:
//   pipeline WxH cpu_ms_per_frame=X hz_one_core=X slips_at_30hz=N latency_p50_ms=X
//   latency_p99_ms=X sgbm64_ratio=X
//
//   pipeline [--sizes 640x480,1280x960] [--sim-s 4] [--realtime-s 10] [--sams-threads 2] [--regolith PATH]
// (sams runs its channels on `--sams-threads` threads; its CPU is summed over them)
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "cli_support.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/terrain_scene/terrain_scene.hpp"

extern char** environ;

using namespace regolith;
namespace fs = std::filesystem;

namespace {

constexpr double kHfov = 1.349;  // rad, the mocked rover's front camera (77 deg)
constexpr double kRateHz = 30.0;

int g_sams_threads = 2;

std::string deployment(int w, int h, const std::string& ns) {
  const double fx = 0.5 * w / std::tan(0.5 * kHfov);
  char buf[2048];
  std::snprintf(buf, sizeof buf, R"(name: pipeline_%dx%d
dds: {enabled: true, namespace: %s}
rover:
  cameras:
    front:
      camera_info: {width: %d, height: %d, k: [%.6f, 0, %.1f, 0, %.6f, %.1f, 0, 0, 1]}
      mount: {z_m: 0.5, pitch_rad: 0.35}
sun: {azimuth_deg: 216.76, elevation_deg: 34.38}
devices:
  cameras:
    front: {backend: synthetic_terrain, rate_hz: %.1f, frames: 4, speed_m_s: 0.1, noise_sigma: 0.01}
rate_groups:
  - {name: terrain, rate_hz: %.1f, members: [sfs, sams, traversability]}
components:
  sfs: {type: sfs, camera: front}
  sams: {type: sams, camera: front, threads: %d, hazard_size_m: 0.15, center_x_m: 2.5, length_x_m: 3.0, length_y_m: 3.0}
  traversability: {type: traversability, camera: front, extra_layers: [rock_probability],
                   center_x_m: 2.5, length_x_m: 3.0, length_y_m: 3.0}
)",
                w, h, ns.c_str(), w, h, fx, 0.5 * (w - 1), fx, 0.5 * (h - 1), kRateHz, kRateHz, g_sams_threads);
  return buf;
}

double thread_cpu_ms() {
  return static_cast<double>(thread_cpu_now()) * 1e-6;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto i = static_cast<std::size_t>(pos);
  const double f = pos - static_cast<double>(i);
  return i + 1 < v.size() ? v[i] * (1 - f) + v[i + 1] * f : v[i];
}

struct MemberCpu {
  std::string name;
  double total_ms = 0;  // CPU in step over the window (its workers' included)
  double wall_ms = 0;   // elapsed time in step over the window
};

std::vector<MemberCpu> member_cpu(const runtime::Application& app) {
  std::vector<MemberCpu> out;
  for (const auto* c : app.view().components) {
    const auto s = c->cpu().summary();
    const auto wl = c->wall().summary();
    out.push_back({c->name(), static_cast<double>(s.mean) * static_cast<double>(s.count) * 1e-6,
                   static_cast<double>(wl.mean) * static_cast<double>(wl.count) * 1e-6});
  }
  return out;
}

std::uint64_t group_cycles(const runtime::Application& app) {
  std::uint64_t n = 0;
  for (const auto* g : app.view().groups) n += g->counters().cycles;
  return n;
}

// 3. Peer: StereoSGBM, 64 disparities, one thread, on a rendered frame of the same size and a
// copy shifted by 8 px. Timed between the simulated-clock windows of the pipeline (below), so a
// shared host that slows down or speeds up during the run moves both sides of the ratio alike.
class SgbmPeer {
 public:
  SgbmPeer(int w, int h) : sgbm_(cv::StereoSGBM::create(0, 64, 5)) {
    terrain_scene::SceneParams sp;
    const terrain_scene::Terrain terrain(sp);
    terrain_scene::CameraPose cam;
    cam.width = w;
    cam.height = h;
    cam.fx = cam.fy = 0.5 * w / std::tan(0.5 * kHfov);
    cam.cx = 0.5 * (w - 1);
    cam.cy = 0.5 * (h - 1);
    cam.height_m = 0.5;
    cam.pitch_rad = 0.35;
    const auto img = terrain_scene::render_camera(terrain, cam, terrain_scene::Sun{-3.78, 0.6}, {});
    left_ = terrain_scene::to_u8(img.image);
    const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, -8, 0, 1, 0);
    cv::warpAffine(left_, right_, shift, left_.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    once();  // warm-up
  }
  // CPU ms of one disparity map on one thread.
  double once() {
    const int threads = cv::getNumThreads();
    cv::setNumThreads(1);
    const double t0 = thread_cpu_ms();
    sgbm_->compute(left_, right_, disp_);
    const double ms = thread_cpu_ms() - t0;
    cv::setNumThreads(threads);
    return ms;
  }

 private:
  cv::Ptr<cv::StereoSGBM> sgbm_;
  cv::Mat left_, right_, disp_;
};

// 1. Simulated clock: CPU per frame per member.
struct SimResult {
  double cpu_ms = 0;               // pipeline CPU per frame over all windows
  std::vector<double> peer_ms;     // the peer, once after each window
  std::vector<double> peer_ratio;  // per window: peer ms / pipeline CPU ms per frame
};

SimResult cpu_per_frame(int w, int h, double sim_s, SgbmPeer& peer) {
  auto app = runtime::Application::load(Params::load_string(deployment(w, h, "pipeline_sim"), "<pipeline>"),
                                        {.sim_time = true, .enable_dds = true});
  std::atomic<bool> stop{false};
  app->start();
  app->run(static_cast<TimeNs>(1.0 * static_cast<double>(kNsPerSec)), stop);  // warm-up: buffers, plans
  const auto c0 = member_cpu(*app);
  const std::uint64_t n0 = group_cycles(*app);
  // Windows of 0.5 s (15 frames), each followed by one peer run.
  SimResult res;
  const int windows = std::max(4, static_cast<int>(std::lround(sim_s / 0.5)));
  const auto window = static_cast<TimeNs>(sim_s / windows * static_cast<double>(kNsPerSec));
  auto pipeline_ms = [](const std::vector<MemberCpu>& c) {
    double ms = 0;
    for (const auto& m : c) ms += m.total_ms;
    return ms;
  };
  for (int i = 0; i < windows; ++i) {
    const double before = pipeline_ms(member_cpu(*app));
    const std::uint64_t nb = group_cycles(*app);
    app->run(window, stop);
    const double frames = static_cast<double>(std::max<std::uint64_t>(1, group_cycles(*app) - nb));
    const double per_frame = (pipeline_ms(member_cpu(*app)) - before) / frames;
    res.peer_ms.push_back(peer.once());
    res.peer_ratio.push_back(res.peer_ms.back() / per_frame);
  }
  const auto c1 = member_cpu(*app);
  const std::uint64_t frames = group_cycles(*app) - n0;
  app->stop();
  std::printf("  simulated clock, %llu frames at %.0f Hz, per frame:   CPU (all its threads)   elapsed   CPU ms/Mpx\n",
              static_cast<unsigned long long>(frames), kRateHz);
  const double mpx = static_cast<double>(w) * static_cast<double>(h) * 1e-6;
  const double nf = static_cast<double>(std::max<std::uint64_t>(1, frames));
  double wall = 0;
  for (std::size_t i = 0; i < c1.size(); ++i) {
    const double ms = (c1[i].total_ms - c0[i].total_ms) / nf, wms = (c1[i].wall_ms - c0[i].wall_ms) / nf;
    res.cpu_ms += ms;
    wall += wms;
    std::printf("    %-16s %8.2f ms %8.2f ms %8.1f\n", c1[i].name.c_str(), ms, wms, ms / mpx);
  }
  std::printf("    %-16s %8.2f ms %8.2f ms %8.1f\n", "total", res.cpu_ms, wall, res.cpu_ms / mpx);
  return res;
}

// 2. Real time: slips and latency from another process.
struct RealTime {
  std::uint64_t slips = 0, cycles = 0;
  std::vector<double> latency_ms;
};

RealTime real_time(int w, int h, double seconds, const std::string& regolith) {
  RealTime r;
  const std::string ns = "pipeline" + std::to_string(::getpid());
  const fs::path out = fs::temp_directory_path() / (ns + "_echo.jsonl");
  const std::string count = std::to_string(static_cast<int>(seconds * kRateHz * 2));
  const std::string timeout = std::to_string(static_cast<int>(seconds + 30));
  std::vector<std::string> args = {regolith,  "echo", "terrain/rocks", "--namespace", ns,
                                   "--delay", "-n",   count,           "--timeout",   timeout};
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  pid_t pid = -1;
  if (posix_spawn(&pid, regolith.c_str(), &fa, nullptr, argv.data(), environ) != 0) pid = -1;
  posix_spawn_file_actions_destroy(&fa);
  if (pid < 0) {
    std::fprintf(stderr, "pipeline: cannot start %s (latency not measured)\n", regolith.c_str());
  }
  {
    auto app = runtime::Application::load(
        Params::load_string(deployment(w, h, ns), "<pipeline>"),
        {.sim_time = false,
         .enable_dds = true,
         .wait_for = pid > 0 ? std::vector<std::string>{"terrain/rocks"} : std::vector<std::string>{},
         .wait_timeout = 20 * kNsPerSec});
    std::atomic<bool> stop{false};
    app->start();
    app->run(static_cast<TimeNs>(1.0 * static_cast<double>(kNsPerSec)), stop);  // warm-up
    std::uint64_t s0 = 0, n0 = 0;
    for (const auto* g : app->view().groups) {
      s0 += g->counters().slips;
      n0 += g->counters().cycles;
    }
    app->run(static_cast<TimeNs>(seconds * static_cast<double>(kNsPerSec)), stop);
    for (const auto* g : app->view().groups) {
      r.slips += g->counters().slips;
      r.cycles += g->counters().cycles;
    }
    r.slips -= s0;
    r.cycles -= n0;
    app->stop();
  }
  if (pid > 0) {
    std::this_thread::sleep_for(std::chrono::milliseconds(300));  // the last samples reach the reader
    ::kill(pid, SIGINT);
    int status = 0;
    ::waitpid(pid, &status, 0);
    std::ifstream in(out);
    std::string line;
    std::size_t skipped = 0;
    while (std::getline(in, line)) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      if (j.is_discarded() || !j.contains("delay_ms")) continue;
      // the first second (warm-up) is not scored: skip samples until the group is warm
      if (skipped < static_cast<std::size_t>(kRateHz)) {
        ++skipped;
        continue;
      }
      r.latency_ms.push_back(j["delay_ms"].get<double>());
    }
    fs::remove(out);
  }
  return r;
}

bool parse_size(const std::string& s, int& w, int& h) {
  return std::sscanf(s.c_str(), "%dx%d", &w, &h) == 2 && w >= 64 && h >= 48 && w <= 4096 && h <= 4096;
}

int usage(const std::string& why) {
  std::fprintf(stderr,
               "pipeline: %s\nusage: pipeline [--sizes 640x480,1280x960] [--sim-s 4] [--realtime-s 10] "
               "[--sams-threads 2] [--regolith PATH]\n",
               why.c_str());
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::pair<int, int>> sizes;
  std::string size_list = "640x480,1280x960";
  double sim_s = 4.0, realtime_s = 10.0;
  std::string regolith = REGOLITH_EXE;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (i + 1 >= argc && a != "-h" && a != "--help") return usage("'" + a + "' needs a value");
    if (a == "--sizes")
      size_list = argv[++i];
    else if (a == "--sim-s")
      sim_s = std::atof(argv[++i]);
    else if (a == "--realtime-s")
      realtime_s = std::atof(argv[++i]);
    else if (a == "--regolith")
      regolith = argv[++i];
    else if (a == "--sams-threads")
      g_sams_threads = std::atoi(argv[++i]);
    else if (a == "-h" || a == "--help")
      return usage("the forward pipeline bench"), 0;
    else
      return usage("unknown argument '" + a + "'");
  }
  if (!(sim_s > 0 && sim_s <= 600) || !(realtime_s > 0 && realtime_s <= 3600))
    return usage("--sim-s and --realtime-s must be > 0 (at most 600 / 3600)");
  std::stringstream ss(size_list);
  for (std::string s; std::getline(ss, s, ',');) {
    int w = 0, h = 0;
    if (!parse_size(s, w, h)) return usage("--sizes: '" + s + "' is not WxH (64x48 .. 4096x4096)");
    sizes.emplace_back(w, h);
  }
  cli::register_everything();
  std::vector<std::string> lines;
  for (const auto& [w, h] : sizes) {
    std::printf("pipeline %dx%d: sfs + sams (%d threads) + traversability, one %.0f Hz rate group, DDS on\n", w, h,
                g_sams_threads, kRateHz);
    SgbmPeer peer(w, h);
    const SimResult sim = cpu_per_frame(w, h, sim_s, peer);
    const double cpu = sim.cpu_ms;
    const RealTime rt = real_time(w, h, realtime_s, regolith);
    const double sgbm = quantile(sim.peer_ms, 0.5), ratio = quantile(sim.peer_ratio, 0.5);
    const double p50 = quantile(rt.latency_ms, 0.5), p99 = quantile(rt.latency_ms, 0.99);
    std::printf(
        "  real time %.0f s: %llu cycles, %llu slips; terrain/rocks capture -> receipt in another process "
        "(%zu samples): p50 %.1f ms, p99 %.1f ms\n",
        realtime_s, static_cast<unsigned long long>(rt.cycles), static_cast<unsigned long long>(rt.slips),
        rt.latency_ms.size(), p50, p99);
    std::printf(
        "  peer: StereoSGBM 64 disparities, one thread, same size, once after each of the %zu simulated-clock windows: "
        "median %.1f ms per frame; peer / pipeline per window: median %.1fx (%.1f .. %.1f)\n",
        sim.peer_ms.size(), sgbm, ratio, quantile(sim.peer_ratio, 0.0), quantile(sim.peer_ratio, 1.0));
    char line[512];
    std::snprintf(line, sizeof line,
                  "pipeline %dx%d cpu_ms_per_frame=%.2f hz_one_core=%.1f slips_at_30hz=%llu latency_p50_ms=%.1f "
                  "latency_p99_ms=%.1f sgbm64_ratio=%.1f",
                  w, h, cpu, 1000.0 / cpu, static_cast<unsigned long long>(rt.slips), p50, p99, ratio);
    lines.emplace_back(line);
    std::printf("%s\n", line);
    std::fflush(stdout);
  }
  return 0;
}
