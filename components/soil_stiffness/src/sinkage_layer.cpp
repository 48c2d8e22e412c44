#include "regolith/soil_stiffness/sinkage_layer.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace regolith::soil {

void fill_sinkage_layer(const SoilEstimate& e, double wheel_width_m, const LayerPose& pose, std::int64_t stamp_ns,
                        std::uint64_t sequence, SinkageLayer& out) {
  constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();
  out.stamp_ns = stamp_ns;
  out.sequence = sequence;
  out.pose = pose;
  out.valid = e.ok && !e.tracks.empty();
  out.track_count = out.valid ? static_cast<std::uint32_t>(std::min(e.tracks.size(), kLayerMaxTracks)) : 0;
  const double c = std::cos(pose.mount_yaw_rad), s = std::sin(pose.mount_yaw_rad);
  for (std::uint32_t t = 0; t < out.track_count; ++t) {
    const TrackProfile& p = e.tracks[t];
    SinkageLayerTrack& o = out.tracks[t];
    o.lateral_m = p.lateral_m;
    o.width_m = wheel_width_m;
    o.load_n = p.load_n;
    o.mean_sinkage_m = p.mean_sinkage_m;
    const std::size_t n = std::min(p.range_m.size(), p.sinkage_m.size());
    const std::size_t group = n == 0 ? 1 : (n + kLayerMaxSamples - 1) / kLayerMaxSamples;
    std::uint32_t k = 0;
    for (std::size_t a = 0; a < n && k < kLayerMaxSamples; a += group, ++k) {
      const std::size_t b = std::min(n, a + group);
      double r = 0.0, z = 0.0;
      int nz = 0;
      for (std::size_t q = a; q < b; ++q) {
        r += p.range_m[q];
        if (std::isfinite(p.sinkage_m[q])) {
          z += p.sinkage_m[q];
          ++nz;
        }
      }
      r /= static_cast<double>(b - a);
      o.range_m[k] = static_cast<float>(r);
      o.x_m[k] = static_cast<float>(pose.mount_x_m + c * r - s * p.lateral_m);
      o.y_m[k] = static_cast<float>(pose.mount_y_m + s * r + c * p.lateral_m);
      o.sinkage_m[k] = nz > 0 ? static_cast<float>(z / nz) : kNaNf;
    }
    o.count = k;
  }
}

}  // namespace regolith::soil
