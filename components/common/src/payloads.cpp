#include "regolith/common/payloads.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace regolith::common {

int rasterise_sinkage(const SinkageLayer& layer, const GridGeometry& g, cv::Mat& out) {
  g.validate();
  const int sx = g.size_x(), sy = g.size_y();
  out.create(sx, sy, CV_32F);
  // A plain loop: cv::Mat::setTo converts its scalar through a heap buffer, and this runs in a
  // rate-group cycle (the traversability component merges the layer every terrain cycle).
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int r = 0; r < out.rows; ++r) {
    float* row = out.ptr<float>(r);
    for (int c = 0; c < out.cols; ++c) row[c] = nan;
  }
  if (!layer.valid) return 0;
  const double x_top = g.center_x_m + 0.5 * g.length_x_m, y_top = g.center_y_m + 0.5 * g.length_y_m;
  const double res = g.resolution_m;
  int set = 0;
  for (std::uint32_t t = 0; t < std::min<std::uint32_t>(layer.track_count, kLayerMaxTracks); ++t) {
    const SinkageLayerTrack& tr = layer.tracks[t];
    const double half_w = 0.5 * tr.width_m;
    // each segment between consecutive samples carries the nearer sample's sinkage: test every
    // cell of the segment's bounding box for its distance to the segment (across <= b/2)
    for (std::uint32_t k = 0; k < tr.count; ++k) {
      const float z = tr.sinkage_m[k];
      if (!std::isfinite(z)) continue;
      // half-way to the neighbours along the track
      const std::uint32_t kp = k > 0 ? k - 1 : k, kn = k + 1 < tr.count ? k + 1 : k;
      const double ax = 0.5 * (tr.x_m[kp] + tr.x_m[k]), ay = 0.5 * (tr.y_m[kp] + tr.y_m[k]);
      const double bx = 0.5 * (tr.x_m[kn] + tr.x_m[k]), by = 0.5 * (tr.y_m[kn] + tr.y_m[k]);
      const double dx = bx - ax, dy = by - ay, len2 = dx * dx + dy * dy;
      const double xmin = std::min(ax, bx) - half_w, xmax = std::max(ax, bx) + half_w;
      const double ymin = std::min(ay, by) - half_w, ymax = std::max(ay, by) + half_w;
      const int i0 = std::max(0, static_cast<int>(std::floor((x_top - xmax) / res)));
      const int i1 = std::min(sx - 1, static_cast<int>(std::floor((x_top - xmin) / res)));
      const int j0 = std::max(0, static_cast<int>(std::floor((y_top - ymax) / res)));
      const int j1 = std::min(sy - 1, static_cast<int>(std::floor((y_top - ymin) / res)));
      for (int i = i0; i <= i1; ++i) {
        float* row = out.ptr<float>(i);
        const double px = x_top - (i + 0.5) * res;
        for (int j = j0; j <= j1; ++j) {
          const double py = y_top - (j + 0.5) * res;
          double u = len2 > 0 ? ((px - ax) * dx + (py - ay) * dy) / len2 : 0.0;
          if (len2 > 0 && (u < 0.0 || u > 1.0)) continue;  // outside this sample's stretch
          u = std::clamp(u, 0.0, 1.0);
          const double qx = ax + u * dx - px, qy = ay + u * dy - py;
          if (qx * qx + qy * qy > half_w * half_w) continue;
          if (!std::isfinite(row[j])) ++set;
          row[j] = z;
        }
      }
    }
  }
  return set;
}

}  // namespace regolith::common
