// `regolith calibrate sinkage` and `regolith eval sinkage`: tools/cmd_sinkage.cpp compiled into this
// binary (cli_stub.cpp stands in for tools/main.cpp's helpers). Output numbers are checked against
// the synthetic ground truth; bad input raises InputError / ConfigError naming the file and line
// (tools/main.cpp maps both to exit code 2).
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <yaml-cpp/yaml.h>

#include "regolith/core/error.hpp"
#include "regolith/sinkage/bench_log.hpp"
#include "regolith/wheel_scene/wheel_scene.hpp"
#include "temp_dir.hpp"

namespace regolith::cli {
void add_sinkage_commands(CLI::App& app);
}

namespace fs = std::filesystem;
namespace ws = regolith::wheel_scene;

namespace {

/// Runs the CLI in-process and returns what it printed.
std::string run_cli(const std::vector<std::string>& args) {
  CLI::App app{"test"};
  regolith::cli::add_sinkage_commands(app);
  std::vector<const char*> argv{"regolith"};
  for (const auto& a : args) argv.push_back(a.c_str());
  ::testing::internal::CaptureStdout();
  try {
    app.parse(static_cast<int>(argv.size()), const_cast<char**>(argv.data()));
  } catch (...) {
    ::testing::internal::GetCapturedStdout();
    throw;
  }
  return ::testing::internal::GetCapturedStdout();
}

template <class E>
std::string error_of(const std::vector<std::string>& args) {
  try {
    run_cli(args);
  } catch (const E& e) {
    return e.what();
  }
  return "<no error>";
}

struct TableRow {
  std::string load, light;
  int frames = 0, valid = 0;
  double mean_mm = 0, max_mm = 0, mean_pct_gt = 0, mean_pct_max = 0, max_pct_max = 0;
};

/// Parses format_table() rows ("3.5 kg  300-400 lux  48 48 0.10 ...": two-word labels).
std::vector<TableRow> parse_table(const std::string& out) {
  std::vector<TableRow> rows;
  std::istringstream is(out);
  for (std::string line; std::getline(is, line);) {
    if (line.empty() || line[0] == '#' || line.rfind("load", 0) == 0) continue;
    std::istringstream ls(line);
    TableRow r;
    std::string l1, l2, i1, i2;
    ls >> l1 >> l2 >> i1 >> i2 >> r.frames >> r.valid >> r.mean_mm >> r.max_mm >> r.mean_pct_gt >> r.mean_pct_max >>
        r.max_pct_max;
    if (!ls) continue;
    r.load = l1 + " " + l2;
    r.light = i1 + " " + i2;
    rows.push_back(r);
  }
  return rows;
}

}  // namespace

TEST(SinkageCli, CalibratePrintsTheGeometryBlockOfTheUnsunkWheel) {
  const regolith::testing::TempDir tmp("sinkage_cli_cal");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  ws::SceneParams sp;
  ws::WheelSceneGenerator gen(sp);
  cv::Mat bgr;
  gen.render_at_soil_level(0.3, 470.0, bgr);  // soil below every tip: un-sunk
  const fs::path png = dir / "unsunk.png";
  ASSERT_TRUE(cv::imwrite(png.string(), bgr));
  const std::string out =
      run_cli({"calibrate", "sinkage", png.string(), "--angle", "0.3", "--overlay", (dir / "cal.png").string()});
  ASSERT_EQ(out.rfind("# regolith calibrate sinkage ", 0), 0u) << out;
  const YAML::Node g = YAML::Load(out)["geometry"];
  ASSERT_TRUE(g) << out;
  EXPECT_NEAR(g["hub_center_px"][0].as<double>(), 320.0, 2.0);
  EXPECT_NEAR(g["hub_center_px"][1].as<double>(), 110.0, 2.0);
  EXPECT_NEAR(g["leg_length_px"].as<double>(), 300.0, 3.0);
  EXPECT_NEAR(g["leg_width_px"].as<double>(), 28.0, 2.0);
  EXPECT_EQ(g["leg_count"].as<int>(), 5);
  // The angle offset is defined modulo the leg spacing.
  const double spacing = g["leg_spacing_rad"].as<double>();
  double off = std::fmod(g["angle_offset_rad"].as<double>(), spacing);
  if (off > spacing / 2) off -= spacing;
  if (off < -spacing / 2) off += spacing;
  EXPECT_NEAR(off, 0.0, 1.0 * 3.14159265 / 180.0);
  EXPECT_TRUE(fs::exists(dir / "cal.png"));
}

TEST(SinkageCli, CalibrateBadInputNamesTheFile) {
  const regolith::testing::TempDir tmp("sinkage_cli_calbad");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  EXPECT_EQ(error_of<regolith::InputError>({"calibrate", "sinkage", (dir / "missing.png").string(), "--angle", "0"}),
            (dir / "missing.png").string() + ": cannot read image: cannot open it");
  // A frame without any blue leg.
  const fs::path grey = dir / "grey.png";
  cv::imwrite(grey.string(), cv::Mat(480, 640, CV_8UC3, cv::Scalar(120, 120, 120)));
  const std::string e = error_of<regolith::InputError>({"calibrate", "sinkage", grey.string(), "--angle", "0"});
  EXPECT_EQ(e.rfind(grey.string() + ": calibration failed: ", 0), 0u) << e;
}

// The four synthetic conditions; writing them and evaluating the written sequences gives the same
// table (PNG is lossless), so the recorded-sequence path is checked against the same truth.
TEST(SinkageCli, EvalSyntheticAndRecordedSequencesGiveTheTable) {
  const regolith::testing::TempDir tmp("sinkage_cli_eval");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const std::string out = run_cli({"eval", "sinkage", "--synthetic", "--frames", "16", "--write", dir.string()});
  const auto rows = parse_table(out);
  ASSERT_EQ(rows.size(), 4u) << out;
  const char* loads[] = {"3.5 kg", "3.5 kg", "1.0 kg", "1.0 kg"};
  const char* lights[] = {"300-400 lux", "10-15 lux", "300-400 lux", "10-15 lux"};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(rows[i].load, loads[i]);
    EXPECT_EQ(rows[i].light, lights[i]);
    EXPECT_EQ(rows[i].frames, 16);
    EXPECT_GE(rows[i].valid, 15);
    EXPECT_LE(rows[i].mean_pct_max, 5.0) << out;  // issue target: mean <= 5 % of the maximum sinkage
    EXPECT_LT(rows[i].max_mm, 4.0) << out;
    EXPECT_GT(rows[i].mean_mm, 0.0);
  }
  // Recorded sequences: labels from the CSV comments.
  std::vector<std::string> args{"eval", "sinkage"};
  for (const char* sub : {"3_5_kg_normal", "3_5_kg_poor", "1_0_kg_normal", "1_0_kg_poor"}) {
    args.push_back("--sequence");
    args.push_back((dir / sub).string());
  }
  const auto again = parse_table(run_cli(args));
  ASSERT_EQ(again.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(again[i].load, rows[i].load);
    EXPECT_EQ(again[i].light, rows[i].light);
    EXPECT_EQ(again[i].valid, rows[i].valid);
    EXPECT_NEAR(again[i].mean_mm, rows[i].mean_mm, 0.011);
    EXPECT_NEAR(again[i].max_mm, rows[i].max_mm, 0.011);
  }
}

// Bare `regolith eval sinkage` (the form outside scripts call) evaluates the synthetic conditions.
TEST(SinkageCli, EvalWithoutInputsRunsTheSyntheticConditions) {
  const std::string bare = run_cli({"eval", "sinkage", "--frames", "4"});
  EXPECT_NE(bare.find("# no --sequence or --log given: the synthetic conditions (--synthetic)"), std::string::npos)
      << bare;
  const auto rows = parse_table(bare);
  const auto synthetic = parse_table(run_cli({"eval", "sinkage", "--synthetic", "--frames", "4"}));
  ASSERT_EQ(rows.size(), 4u) << bare;
  ASSERT_EQ(synthetic.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(rows[i].load, synthetic[i].load);
    EXPECT_EQ(rows[i].light, synthetic[i].light);
    EXPECT_EQ(rows[i].frames, 4);
    EXPECT_EQ(rows[i].valid, synthetic[i].valid);
    EXPECT_DOUBLE_EQ(rows[i].mean_mm, synthetic[i].mean_mm);
  }
}

TEST(SinkageCli, EvalBenchLogGroupsConditions) {
  const regolith::testing::TempDir tmp("sinkage_cli_log");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path log = dir / "bench.csv";
  {
    std::ofstream os(log);
    os << "# a bench log\n" << regolith::sinkage::bench_log_header() << "\n";
    char line[256];
    // 3.5 kg: errors 1, 2 mm on 20 / 40 mm; one invalid frame; one row without a transducer reading.
    auto row = [&](double vis, bool valid, double truth, const char* load, const char* light) {
      regolith::sinkage::format_bench_log_row(line, sizeof line, 1.0, 0, 0.1, vis, valid, valid ? 0.9 : 0.0,
                                              valid ? "none" : "no_leg_pixels", truth, load, light);
      os << line << "\n";
    };
    row(21.0, true, 20.0, "3.5 kg", "300-400 lux");
    row(38.0, true, 40.0, "3.5 kg", "300-400 lux");
    row(0.0, false, 30.0, "3.5 kg", "300-400 lux");
    row(10.0, true, std::nan(""), "3.5 kg", "300-400 lux");
    row(10.5, true, 10.0, "1.0 kg", "10-15 lux");
  }
  const std::string out = run_cli({"eval", "sinkage", "--log", log.string()});
  EXPECT_NE(out.find("# 1 log rows without a transducer reading were left out"), std::string::npos) << out;
  const auto rows = parse_table(out);
  ASSERT_EQ(rows.size(), 2u) << out;
  EXPECT_EQ(rows[0].load, "3.5 kg");
  EXPECT_EQ(rows[0].frames, 3);
  EXPECT_EQ(rows[0].valid, 2);
  EXPECT_NEAR(rows[0].mean_mm, 1.5, 1e-9);
  EXPECT_NEAR(rows[0].max_mm, 2.0, 1e-9);
  EXPECT_NEAR(rows[0].mean_pct_gt, 5.0, 0.051);  // 1.5 / 30
  EXPECT_NEAR(rows[0].max_pct_max, 5.0, 0.051);  // 2 / 40
  EXPECT_EQ(rows[1].light, "10-15 lux");
  EXPECT_NEAR(rows[1].mean_mm, 0.5, 1e-9);
}

TEST(SinkageCli, EvalBadInputNamesFileAndLine) {
  const regolith::testing::TempDir tmp("sinkage_cli_evalbad");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  // Malformed sequence CSV.
  const fs::path csv = dir / "seq.csv";
  std::ofstream(csv) << "frame,encoder_angle_rad,truth_mm\nf0.png,0.1,12\nf1.png,0.2,abc\n";
  EXPECT_EQ(error_of<regolith::InputError>({"eval", "sinkage", "--sequence", csv.string()}),
            csv.string() + ":3: column truth_mm: expected a finite number (got 'abc')");
  // Good CSV, missing image.
  std::ofstream(csv) << "frame,encoder_angle_rad,truth_mm\n# comment\nf0.png,0.1,12\n";
  EXPECT_EQ(error_of<regolith::InputError>({"eval", "sinkage", "--sequence", csv.string()}),
            csv.string() + ":3: cannot read image '" + (dir / "f0.png").string() + "': cannot open it");
  // Bench log with a bad valid flag.
  const fs::path log = dir / "log.csv";
  std::ofstream(log) << regolith::sinkage::bench_log_header() << "\n1.0,0,0.1,12,yes,0.9,none,12,a,b\n";
  EXPECT_EQ(error_of<regolith::InputError>({"eval", "sinkage", "--log", log.string()}),
            log.string() + ":2: column valid: expected 0 or 1 (got 'yes')");
  std::ofstream(log) << "time,vision\n";
  EXPECT_EQ(
      error_of<regolith::InputError>({"eval", "sinkage", "--log", log.string()}).substr(0, log.string().size() + 20),
      log.string() + ":1: expected header ");
  // A parameter file with a bad geometry names the field (ConfigError, exit code 2 as well).
  const fs::path params = dir / "params.yaml";
  std::ofstream(params) << "geometry:\n  hub_center_px: [320, 110]\n  leg_length_px: 300\n  leg_width_px: -3\n";
  const std::string e =
      error_of<regolith::ConfigError>({"eval", "sinkage", "--synthetic", "--params", params.string()});
  EXPECT_EQ(e, params.string() + ":4:17: geometry.leg_width_px: value must be > 0 (got -3)");
}
