// McapWriter throughput against its peer, plain fwrite() of the same payload bytes to a file in
// the same directory (the issue 18 goal: within 2x of raw writes). A rover-like mix per "cycle":
// one 640x480 mono frame (307,200 B, synthetic terrain-like texture, compressible like a real
// image), 10 encoder samples of 64 B, 1 IMU sample of 96 B. Reports MB/s of payload (counter
// "MB", a rate: MB/s) and, for the MCAP runs, the file size relative to the payload ("ratio").
// Run: build/release/bench/record/bench_mcap_write [--benchmark_min_time=2s]
// Files go to $TMPDIR (default /tmp); the page cache absorbs them, so this measures the CPU cost
// of the writer (CRCs, compression, copies), not the disk.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <benchmark/benchmark.h>

#include "regolith/record/mcap_writer.hpp"

namespace {

using regolith::record::Compression;
namespace fs = std::filesystem;

constexpr int kCycles = 200;  // per iteration: 200 frames = ~61 MB of payload

struct Payloads {
  std::vector<std::uint8_t> frame, encoder, imu;
  Payloads() : frame(640 * 480), encoder(64), imu(96) {
    std::uint32_t noise = 12345;
    for (int y = 0; y < 480; ++y)
      for (int x = 0; x < 640; ++x) {
        noise = noise * 1664525U + 1013904223U;
        const double v = 120 + 40 * std::sin(x * 0.05) * std::cos(y * 0.03) + static_cast<double>(noise >> 29);
        frame[static_cast<std::size_t>(y * 640 + x)] = static_cast<std::uint8_t>(v);
      }
    for (std::size_t i = 0; i < encoder.size(); ++i) encoder[i] = static_cast<std::uint8_t>(i);
    for (std::size_t i = 0; i < imu.size(); ++i) imu[i] = static_cast<std::uint8_t>(3 * i);
  }
  std::uint64_t cycle_bytes() const { return frame.size() + 10 * encoder.size() + imu.size(); }
};

const Payloads& payloads() {
  static const Payloads p;
  return p;
}

fs::path out_path(const char* name) {
  return fs::temp_directory_path() / name;
}

void BM_Fwrite(benchmark::State& state) {
  const auto& p = payloads();
  const fs::path path = out_path("regolith_bench_raw.bin");
  for (auto _ : state) {
    std::FILE* f = std::fopen(path.c_str(), "wb");
    for (int c = 0; c < kCycles; ++c) {
      std::fwrite(p.frame.data(), 1, p.frame.size(), f);
      for (int e = 0; e < 10; ++e) std::fwrite(p.encoder.data(), 1, p.encoder.size(), f);
      std::fwrite(p.imu.data(), 1, p.imu.size(), f);
    }
    std::fclose(f);
  }
  state.counters["MB"] = benchmark::Counter(static_cast<double>(state.iterations() * kCycles * p.cycle_bytes()) / 1e6,
                                            benchmark::Counter::kIsRate);
  fs::remove(path);
}

void BM_Mcap(benchmark::State& state, Compression compression) {
  const auto& p = payloads();
  const fs::path path = out_path("regolith_bench.mcap");
  std::uint64_t file_bytes = 0;
  for (auto _ : state) {
    regolith::record::McapWriterOptions o;
    o.compression = compression;
    regolith::record::McapWriter w(path, o);
    const auto s = w.add_schema("sensor_msgs/msg/Image", "ros2msg", std::string("uint8[] data\n"));
    const auto cam = w.add_channel(s, "camera", "cdr");
    const auto enc = w.add_channel(s, "encoders", "cdr");
    const auto imu = w.add_channel(s, "imu", "cdr");
    std::uint64_t t = 0;
    for (std::uint32_t c = 0; c < kCycles; ++c) {
      t += 33'000'000;
      w.write(cam, c, t, t, p.frame);
      for (std::uint32_t e = 0; e < 10; ++e) w.write(enc, c * 10 + e, t + e, t + e, p.encoder);
      w.write(imu, c, t, t, p.imu);
    }
    w.close();
    file_bytes = w.stats().file_bytes;
  }
  state.counters["MB"] = benchmark::Counter(static_cast<double>(state.iterations() * kCycles * p.cycle_bytes()) / 1e6,
                                            benchmark::Counter::kIsRate);
  state.counters["ratio"] = static_cast<double>(file_bytes) / static_cast<double>(kCycles * p.cycle_bytes());
  fs::remove(path);
}

BENCHMARK(BM_Fwrite)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Mcap, none, Compression::kNone)->Unit(benchmark::kMillisecond)->UseRealTime();
BENCHMARK_CAPTURE(BM_Mcap, zstd, Compression::kZstd)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace

BENCHMARK_MAIN();
