#pragma once
// A flat-field image (Vignetting::flat_field) read from a file: one reader for the sfs
// component's `flat_field` key and `regolith assess --flat-field`, so both say the same about a
// bad file. Header-only: its callers link opencv_imgcodecs (the algorithm library does not).
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/image_file.hpp"

namespace regolith::sfs {

/// The flat field in `path` as one grey channel; "" when it is usable, else why not: the
/// reader's reason (missing, not an image, truncated, too large, ...) or pixels of 0 (the gain map
/// divides the image by it). `out` is left empty on failure.
inline std::string read_flat_field(const std::string& path, cv::Mat& out) {
  std::string why;
  out = read_image_file(path, cv::IMREAD_GRAYSCALE, &why);
  if (out.empty()) return why.empty() ? "cannot read it" : why;
  double lo = 0.0, hi = 0.0;
  cv::minMaxLoc(out, &lo, &hi);
  if (!(lo > 0.0)) {
    out.release();
    return "it has pixels of 0 (a flat field must be > 0 everywhere: the image is divided by it)";
  }
  return {};
}

}  // namespace regolith::sfs
