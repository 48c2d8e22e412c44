// `regolith soil IMAGE --config ROVER.yaml --out DIR`: the in-process entry point run_soil_file on
// a synthetic image written at test time with the shipped example_rover.yaml, its error messages,
// and the exit code of the real binary for bad input.
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <sys/wait.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/error.hpp"
#include "regolith/soil_stiffness/config.hpp"
#include "regolith/track_scene/track_scene.hpp"
#include "temp_dir.hpp"

using namespace regolith;
namespace fs = std::filesystem;

namespace {

const fs::path kExample = fs::path(REGOLITH_SOURCE_DIR) / "components/soil_stiffness/example_rover.yaml";

using regolith::testing::TempDir;

// The example rover's scene: mocks/track_scene defaults with Yutu-like wheels (b 0.15 m, D 0.30 m,
// W = 140 * 1.62 / 6 = 37.8 N) on soil k = 5e5, n = 1.
track_scene::TrackSceneParams example_scene() {
  track_scene::TrackSceneParams p;
  p.wheel_width_m = 0.15;
  p.wheel_diameter_m = 0.30;
  p.tracks = {{0.4, 37.8}, {-0.4, 37.8}};
  return p;
}

std::string write_text(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
  return p.string();
}

std::string error_of(const fs::path& image, const fs::path& yaml, const fs::path& out) {
  try {
    soil::run_soil_file(image, yaml, out);
  } catch (const ConfigError& e) {
    return std::string("ConfigError: ") + e.what();
  } catch (const InputError& e) {
    return std::string("InputError: ") + e.what();
  }
  return "(no error)";
}

}  // namespace

TEST(SoilCli, WritesPlotsAndJsonForASyntheticImage) {
  TempDir tmp("soil_cli");
  const auto p = example_scene();
  const auto scene = track_scene::generate_track_scene(p);
  const fs::path image = tmp.path() / "tracks.png";
  ASSERT_TRUE(cv::imwrite(image.string(), scene.image));
  const auto f = soil::run_soil_file(image, kExample, tmp.path() / "out");
  ASSERT_TRUE(f.estimate.ok) << f.estimate.reason;
  for (const auto& path : {f.json, f.dtm_png, f.profiles_png, f.pz_png}) {
    ASSERT_TRUE(fs::exists(path)) << path;
    EXPECT_GT(fs::file_size(path), 1000u) << path;
    if (path.extension() == ".png") {
      const cv::Mat png = cv::imread(path.string());
      EXPECT_GT(png.cols, 300) << path;
    }
  }
  std::ifstream is(f.json);
  const auto j = nlohmann::json::parse(is);
  ASSERT_TRUE(j["ok"].get<bool>());
  const double k = j["fixed_n"]["k"].get<double>();
  const double z = j["mean_sinkage_m"].get<double>();
  const double z_true = scene.truth[0].mean_sinkage_m;
  std::printf("cli: k %.4g (truth 5e5), mean sinkage %.2f mm (truth %.2f mm), class %s\n", k, z * 1e3, z_true * 1e3,
              j["soil_class"].get<std::string>().c_str());
  EXPECT_NEAR(k / 5.0e5, 1.0, 0.15);
  EXPECT_NEAR(z / z_true, 1.0, 0.10);
  EXPECT_EQ(j["tracks"].size(), 2u);
  EXPECT_DOUBLE_EQ(j["rover"]["wheel_load_n"].get<double>(), 140.0 * 1.62 / 6.0);
  // the same file as a deployment component section works too
  const std::string deployment = write_text(tmp.path() / "deploy.yaml", R"(name: x
rover:
  mass_kg: 140
  wheels: [{name: a, x_m: 0.3, y_m: 0.4, radius_m: 0.15, width_m: 0.15}, {name: b, x_m: 0.3, y_m: -0.4, radius_m: 0.15, width_m: 0.15},
           {name: c, x_m: 0, y_m: 0.4, radius_m: 0.15, width_m: 0.15}, {name: d, x_m: 0, y_m: -0.4, radius_m: 0.15, width_m: 0.15},
           {name: e, x_m: -0.3, y_m: 0.4, radius_m: 0.15, width_m: 0.15}, {name: f, x_m: -0.3, y_m: -0.4, radius_m: 0.15, width_m: 0.15}]
  cameras:
    rear:
      camera_info_url: file://rear_calibration.yaml
      mount: {x_m: -0.5, z_m: 1.2, pitch_rad: 0.61, yaw_rad: 3.14159265}
sun: {azimuth_deg: 90, elevation_deg: 45}
components:
  other: {type: health}
  soil:
    type: soil_stiffness
    camera: rear
    profile: {source: photoclinometry}
)");
  // The rear camera's calibration as ROS camera_calibration writes it (camera_info_url).
  write_text(tmp.path() / "rear_calibration.yaml", R"(image_width: 640
image_height: 480
camera_name: rear
camera_matrix:
  rows: 3
  cols: 3
  data: [500, 0, 319.5, 0, 500, 239.5, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0, 0, 0, 0, 0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
projection_matrix:
  rows: 3
  cols: 4
  data: [500, 0, 319.5, 0, 0, 500, 239.5, 0, 0, 0, 1, 0]
)");
  const auto g = soil::run_soil_file(image, deployment, tmp.path() / "out2");
  ASSERT_TRUE(g.estimate.ok) << g.estimate.reason;
  EXPECT_NEAR(g.estimate.k_fixed, f.estimate.k_fixed, 1e-9 * f.estimate.k_fixed);
}

TEST(SoilCli, BadInputNamesTheFileOrField) {
  TempDir tmp("soil_cli");
  const fs::path image = tmp.path() / "tracks.png";
  ASSERT_TRUE(cv::imwrite(image.string(), track_scene::generate_track_scene(example_scene()).image));
  EXPECT_EQ(error_of(tmp.path() / "missing.png", kExample, tmp.path() / "o"),
            "InputError: " + (tmp.path() / "missing.png").string() + ": no such image file");
  const std::string not_image = write_text(tmp.path() / "fake.png", "not a png");
  EXPECT_EQ(error_of(not_image, kExample, tmp.path() / "o"),
            "InputError: " + not_image +
                ": cannot decode the image: not an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
  // A PNG cut short (libpng would decode it with a warning and missing rows): refused, named.
  {
    std::ifstream in(image, std::ios::binary);
    std::ostringstream all;
    all << in.rdbuf();
    const std::string bytes = all.str();
    const std::string cut = write_text(tmp.path() / "cut.png", bytes.substr(0, bytes.size() / 2));
    EXPECT_EQ(error_of(cut, kExample, tmp.path() / "o"),
              "InputError: " + cut + ": cannot decode the image: truncated PNG (the data ends before its IEND chunk)");
  }
  EXPECT_EQ(error_of(image, tmp.path() / "nope.yaml", tmp.path() / "o"),
            "ConfigError: " + (tmp.path() / "nope.yaml").string() + ": no such configuration file");
  // The example file with one thing wrong at a time: located errors naming the field.
  std::ifstream ex(kExample);
  std::stringstream buf;
  buf << ex.rdbuf();
  const std::string example = buf.str();
  auto variant = [&](const std::string& name, const std::string& from, const std::string& to) {
    std::string t = example;
    const auto at = t.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) t.replace(at, from.size(), to);
    return write_text(tmp.path() / name, t);
  };
  const std::string neg = variant("neg.yaml", "y_m: 0.4, radius_m: 0.15", "y_m: 0.4, radius_m: -0.15");
  const std::string neg_err = error_of(image, neg, tmp.path() / "o");
  EXPECT_NE(neg_err.find(neg + ":13:"), std::string::npos) << neg_err;
  EXPECT_NE(neg_err.find("rover.wheels[0].radius_m: value must be > 0 (got -0.15)"), std::string::npos) << neg_err;
  const std::string size = variant("size.yaml", "width: 640, height: 480", "width: 320, height: 480");
  const std::string size_err = error_of(image, size, tmp.path() / "o");
  EXPECT_NE(size_err.find("soil_stiffness.camera: rover.cameras.rear is 320x480 px but the frames are 640x480 px"),
            std::string::npos)
      << size_err;
  const std::string cam = variant("cam.yaml", "  camera: rear ", "  camera: back ");
  const std::string cam_err = error_of(image, cam, tmp.path() / "o");
  EXPECT_NE(cam_err.find("soil_stiffness.camera: no rover.cameras.back in this file"), std::string::npos) << cam_err;
  const std::string old = variant("old.yaml", "  camera: rear ",
                                  "  camera_model: {fx: 500, mount_height_m: 1.2, pitch_rad: 0.61}\n  camera: rear ");
  const std::string old_err = error_of(image, old, tmp.path() / "o");
  EXPECT_NE(old_err.find("soil_stiffness.camera_model: no longer read here: the camera is described once"),
            std::string::npos)
      << old_err;
  const std::string top = write_text(tmp.path() / "top.yaml", "rover: {}\n");
  const std::string top_err = error_of(image, top, tmp.path() / "o");
  EXPECT_NE(top_err.find("soil_stiffness: required section is missing"), std::string::npos) << top_err;
  const std::string nocomp = write_text(tmp.path() / "nocomp.yaml", "components:\n  h: {type: health}\n");
  const std::string nocomp_err = error_of(image, nocomp, tmp.path() / "o");
  EXPECT_NE(nocomp_err.find("no component of type soil_stiffness"), std::string::npos) << nocomp_err;
}

TEST(SoilCli, ExitCodeTwoForBadInput) {
#ifndef REGOLITH_EXE
  GTEST_SKIP() << "the regolith executable is not part of this build";
#else
  if (!fs::exists(REGOLITH_EXE)) GTEST_SKIP() << REGOLITH_EXE << " not built";
  TempDir tmp("soil_cli");
  const std::string cmd = std::string(REGOLITH_EXE) + " soil " + (tmp.path() / "missing.png").string() + " --config " +
                          kExample.string() + " --out " + (tmp.path() / "o").string() + " > " +
                          (tmp.path() / "log.txt").string() + " 2>&1";
  const int rc = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(rc));
  EXPECT_EQ(WEXITSTATUS(rc), 2);
  std::ifstream is(tmp.path() / "log.txt");
  std::string log, line;
  while (std::getline(is, line)) log += line + "\n";
  EXPECT_NE(log.find("missing.png: no such image file"), std::string::npos) << log;
  // and a good run through the real binary: exit 0, files written
  const fs::path image = tmp.path() / "tracks.png";
  ASSERT_TRUE(cv::imwrite(image.string(), track_scene::generate_track_scene(example_scene()).image));
  const std::string ok = std::string(REGOLITH_EXE) + " soil " + image.string() + " --config " + kExample.string() +
                         " --out " + (tmp.path() / "o").string() + " > " + (tmp.path() / "log2.txt").string() + " 2>&1";
  EXPECT_EQ(std::system(ok.c_str()), 0);
  EXPECT_TRUE(fs::exists(tmp.path() / "o" / "result.json"));
  EXPECT_TRUE(fs::exists(tmp.path() / "o" / "pz_curves.png"));
#endif
}
