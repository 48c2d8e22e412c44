// `regolith calibrate vignetting FLATFIELD.png`: fits V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6 to a
// flat-field image and prints the YAML block of the sfs component.
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <string>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/sfs/sfs.hpp"

namespace regolith::cli {
namespace {

struct VigOptions {
  std::string file;
  double cx_frac = 0.5, cy_frac = 0.5;
};

void calibrate_vignetting(const VigOptions& o) {
  if (!std::filesystem::exists(o.file)) throw InputError("calibrate vignetting: '" + o.file + "' does not exist");
  std::string why;
  const cv::Mat img = regolith::read_image_file(o.file, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, &why);
  if (img.empty()) throw InputError("calibrate vignetting: cannot read image '" + o.file + "': " + why);
  sfs::VignettingFit fit;
  try {
    fit = sfs::fit_vignetting_polynomial(img, o.cx_frac, o.cy_frac);
  } catch (const std::invalid_argument& e) {
    throw InputError("calibrate vignetting: " + o.file + ": " + e.what());
  }
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "# regolith calibrate vignetting %s: %dx%d px, centre brightness %.4g, rms residual %.4f\n"
                "# V(r) = 1 + a2 r^2 + a4 r^4 + a6 r^6, r = distance from (%.3f W, %.3f H) / half-diagonal\n"
                "vignetting_a2: %.6f\n"
                "vignetting_a4: %.6f\n"
                "vignetting_a6: %.6f\n",
                o.file.c_str(), img.cols, img.rows, fit.f0, fit.rms_residual, o.cx_frac, o.cy_frac, fit.model.a2,
                fit.model.a4, fit.model.a6);
  std::cout << buf;
}

void add_calibrate_vignetting(CLI::App& app) {
  auto o = std::make_shared<VigOptions>();
  CLI::App* cal = group(app, "calibrate", "calibration tools");
  CLI::App* cmd = cal->add_subcommand("vignetting", "fit the radial vignetting polynomial to a flat-field image");
  cmd->add_option("flatfield", o->file, "image of a uniformly lit white target (8/16-bit)")->required();
  cmd->add_option("--cx-frac", o->cx_frac, "centre column as a fraction of the width")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--cy-frac", o->cy_frac, "centre row as a fraction of the height")->check(CLI::Range(0.0, 1.0));
  cmd->callback([o] { calibrate_vignetting(*o); });
}

}  // namespace

[[maybe_unused]] const bool registered_calibrate_vignetting = add_command(add_calibrate_vignetting);

}  // namespace regolith::cli
