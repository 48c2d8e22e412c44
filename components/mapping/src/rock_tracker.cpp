#include "regolith/mapping/rock_tracker.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include <Eigen/Cholesky>
#include <Eigen/LU>

#include "regolith/common/fill.hpp"
#include "regolith/core/error.hpp"
#include "regolith/mapping/rock_sightings.hpp"

namespace regolith::mapping {
namespace {

constexpr float kNaNf = std::numeric_limits<float>::quiet_NaN();

[[noreturn]] void fail(const std::string& field, const std::string& why) {
  throw FieldError("mapping.tracks", field, why);
}

}  // namespace

void RockTrackerParams::validate() const {
  if (max_tracks < 1 || max_tracks > 65536) fail("max_tracks", "must be 1..65536");
  if (!std::isfinite(ground_sigma_m) || ground_sigma_m <= 0) fail("ground_sigma_m", "must be > 0");
  if (!std::isfinite(ray_sigma_m) || ray_sigma_m <= 0) fail("ray_sigma_m", "must be > 0");
  if (!std::isfinite(ray_sigma_per_m) || ray_sigma_per_m < 0) fail("ray_sigma_per_m", "must be >= 0");
  if (!std::isfinite(gate) || gate <= 0) fail("gate", "must be > 0");
  if (max_age_frames < 1) fail("max_age_frames", "must be >= 1");
  if (!std::isfinite(report_tilt_sigma_rad) || report_tilt_sigma_rad < 0) fail("report_tilt_sigma_rad", "must be >= 0");
}

RockTracker::RockTracker(const RockTrackerParams& params, int max_sightings)
    : p_((params.validate(), params)), max_sightings_(std::max(1, max_sightings)) {
  tracks_.resize(static_cast<std::size_t>(p_.max_tracks));
  rays_.resize(static_cast<std::size_t>(max_sightings_));
  matched_.resize(rays_.size());
  taken_.resize(tracks_.size());
  candidates_.reserve(rays_.size() * tracks_.size());
  table_.create(kTrackRows, p_.max_tracks, CV_32F);
  closed_.create(kTrackRows, p_.max_tracks, CV_32F);
  reset();
}

void RockTracker::reset() {
  for (Track& t : tracks_) t.frames = 0;
  common::fill(table_, kNaNf);
  common::fill(closed_, kNaNf);
  count_ = closed_count_ = 0;
  frame_ = opened_ = 0;
}

void RockTracker::close(int slot) {
  Track& t = tracks_[static_cast<std::size_t>(slot)];
  if (t.frames == 0) return;
  write(t, closed_, closed_count_++);
  t.frames = 0;
}

int RockTracker::free_slot() {
  int oldest = 0;
  for (int s = 0; s < p_.max_tracks; ++s) {
    const Track& t = tracks_[static_cast<std::size_t>(s)];
    if (t.frames == 0) return s;
    if (t.last < tracks_[static_cast<std::size_t>(oldest)].last) oldest = s;
  }
  close(oldest);
  return oldest;
}

void RockTracker::add(Track& t, const Ray& r, const cv::Mat& st, int k) {
  if (t.frames == 0) {
    t = Track{};
    t.a = Eigen::Matrix3d::Zero();
    t.a(2, 2) = 1.0 / (p_.ground_sigma_m * p_.ground_sigma_m);  // the contact is near the ground plane (z = 0)
    t.b = Eigen::Vector3d::Zero();
    t.mount_m = r.o.z();
    t.id = ++opened_;
  }
  const double w = 1.0 / (r.sigma * r.sigma);
  const Eigen::Matrix3d m = Eigen::Matrix3d::Identity() - r.d * r.d.transpose();
  t.a += w * m;
  t.b += w * (m * r.o);
  t.p = t.a.ldlt().solve(t.b);
  const double score = st.at<float>(kSightScore, k);
  const double ow = score / std::max(r.range * r.range, 0.25);
  t.score += score;
  t.width_sum += ow * st.at<float>(kSightWidth, k);
  t.radius_sum += ow * r.radius;
  t.weight_sum += ow;
  // Keep the kObservations nearest (heaviest) frames for the height.
  auto weakest = std::min_element(t.obs.begin(), t.obs.end(),
                                  [](const Observation& a, const Observation& b) { return a.weight < b.weight; });
  if (ow > weakest->weight)
    *weakest = {r.o.x(),
                r.o.y(),
                static_cast<double>(st.at<float>(kSightTopSlope, k)),
                ow,
                r.range,
                static_cast<double>(st.at<float>(kSightWidth, k)),
                static_cast<double>(st.at<float>(kSightSigmaLateral, k))};
  ++t.frames;
  t.last = frame_;
}

int RockTracker::update(const cv::Mat& st, const Pose2& foot, double mount_m) {
  ++frame_;
  common::fill(closed_, kNaNf);
  closed_count_ = 0;
  int used = 0;
  if (foot.finite() && std::isfinite(mount_m) && mount_m > 0 && st.type() == CV_32F && st.rows >= kSightRows) {
    // Each sighting's contact ray in the world.
    int n = 0;
    for (; n < std::min(st.cols, max_sightings_); ++n) {
      const float h = st.at<float>(kSightHeight, n);
      if (!std::isfinite(h)) break;
      Ray& r = rays_[static_cast<std::size_t>(n)];
      const double gx = st.at<float>(kSightContactX, n), gy = st.at<float>(kSightContactY, n);
      const double cx = st.at<float>(kSightX, n), cy = st.at<float>(kSightY, n);
      r.range = std::hypot(gx, gy);
      r.radius = std::max(0.0, std::hypot(cx, cy) - r.range);
      const Eigen::Vector2d g = foot.apply(gx, gy);
      r.o = {foot.x, foot.y, mount_m};
      const Eigen::Vector3d v(g.x() - foot.x, g.y() - foot.y, -mount_m);
      r.ground = v.norm();
      r.d = v / r.ground;
      r.sigma = p_.ray_sigma_m + p_.ray_sigma_per_m * r.range;
      r.spread = 0.25 * st.at<float>(kSightWidth, n);
      r.sigma_along = std::max<double>(st.at<float>(kSightSigmaRange, n), r.sigma);
      r.ok = std::isfinite(r.sigma) && r.d.allFinite();
      matched_[static_cast<std::size_t>(n)] = -1;
    }
    // Candidate (sighting, track) pairs within the gate, cheapest first.
    candidates_.clear();
    std::fill(taken_.begin(), taken_.end(), 0);
    if (p_.enabled)
      for (int k = 0; k < n; ++k) {
        const Ray& r = rays_[static_cast<std::size_t>(k)];
        if (!r.ok) continue;
        for (int s = 0; s < p_.max_tracks; ++s) {
          const Track& t = tracks_[static_cast<std::size_t>(s)];
          if (t.frames == 0 || t.last == frame_) continue;
          const Eigen::Vector3d v = t.p - r.o;
          const double along = v.dot(r.d);
          if (!(along > 0)) continue;
          const double across = std::max(0.0, (v - along * r.d).norm() - r.spread) / r.sigma;
          const double off = (along - r.ground) / r.sigma_along;
          if (across < p_.gate && std::abs(off) < p_.gate)
            candidates_.push_back({across * across + off * off, double(k), double(s)});
        }
      }
    std::sort(candidates_.begin(), candidates_.end(), [](const auto& a, const auto& b) { return a[0] < b[0]; });
    for (const auto& c : candidates_) {
      const int k = static_cast<int>(c[1]), s = static_cast<int>(c[2]);
      if (matched_[static_cast<std::size_t>(k)] >= 0 || taken_[static_cast<std::size_t>(s)]) continue;
      matched_[static_cast<std::size_t>(k)] = s;
      taken_[static_cast<std::size_t>(s)] = 1;
    }
    for (int k = 0; k < n; ++k) {
      const Ray& r = rays_[static_cast<std::size_t>(k)];
      if (!r.ok) continue;
      int s = matched_[static_cast<std::size_t>(k)];
      if (s < 0) s = free_slot();
      add(tracks_[static_cast<std::size_t>(s)], r, st, k);
      ++used;
    }
  }
  // Tracks unseen for max_age_frames close (all of them at once when tracking is off).
  for (int s = 0; s < p_.max_tracks; ++s) {
    const Track& t = tracks_[static_cast<std::size_t>(s)];
    if (t.frames > 0 && (!p_.enabled || frame_ - t.last >= p_.max_age_frames)) close(s);
  }
  common::fill(table_, kNaNf);
  count_ = 0;
  for (const Track& t : tracks_)
    if (t.frames > 0) write(t, table_, count_++);
  return used;
}

void RockTracker::write(const Track& t, cv::Mat& table, int col) const {
  const Eigen::Vector3d& p = t.p;
  const double radius = t.weight_sum > 0 ? t.radius_sum / t.weight_sum : 0.0;
  // Centre: the contact pushed back by the footprint radius, away from the nearest view.
  const Observation* near = &t.obs[0];
  for (const Observation& o : t.obs)
    if (o.weight > near->weight) near = &o;
  Eigen::Vector2d u(p.x() - near->ox, p.y() - near->oy);
  const double un = u.norm();
  u = un > 1e-9 ? Eigen::Vector2d(u / un) : Eigen::Vector2d::Zero();
  const Eigen::Vector2d c = p.head<2>() + radius * u;
  // Height: each kept frame's top ray at the centre's distance, above the contact.
  double hs = 0, ws = 0;
  for (const Observation& o : t.obs) {
    if (!(o.weight > 0)) continue;
    const double dist = std::hypot(c.x() - o.ox, c.y() - o.oy);
    hs += o.weight * (t.mount_m + dist * o.slope - p.z());
    ws += o.weight;
  }
  const Eigen::Matrix2d cov = t.a.inverse().topLeftCorner<2, 2>();
  // The errors all frames share, along the nearest frame's view (u) and across it, for the report.
  const Eigen::Vector2d n(-u.y(), u.x());
  const double h = std::max(t.mount_m, 1e-3), rr = near->range;
  const double along2 = std::pow((rr * rr + h * h) / h * p_.report_tilt_sigma_rad, 2) +
                        std::pow(rr / h * p_.ground_sigma_m, 2) + std::pow(0.25 * near->width, 2);
  // Across: which part of the rock the blobs were (a side-lit rock shows one half; its footprint
  // radius is at least its height, RockSightingParams::footprint_per_height): half that radius.
  const double height = ws > 0 ? hs / ws : 0.0;
  const double across2 = std::pow(near->sigma_lateral, 2) + std::pow(0.5 * std::max(radius, height), 2);
  const Eigen::Matrix2d pos = cov + along2 * u * u.transpose() + across2 * n * n.transpose();
  const auto set = [&](TrackRow r, double v) { table.at<float>(r, col) = static_cast<float>(v); };
  set(kTrackX, c.x());
  set(kTrackY, c.y());
  set(kTrackHeight, ws > 0 ? hs / ws : std::numeric_limits<double>::quiet_NaN());
  set(kTrackWidth, t.weight_sum > 0 ? t.width_sum / t.weight_sum : 0.0);
  set(kTrackScore, t.score);
  set(kTrackSxx, cov(0, 0));
  set(kTrackSxy, cov(0, 1));
  set(kTrackSyy, cov(1, 1));
  set(kTrackFrames, t.frames);
  set(kTrackPosXx, pos(0, 0));
  set(kTrackPosXy, pos(0, 1));
  set(kTrackPosYy, pos(1, 1));
  set(kTrackId, static_cast<double>(t.id));
}

}  // namespace regolith::mapping
