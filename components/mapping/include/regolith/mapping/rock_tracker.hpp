#pragma once
// Rocks followed across frames: each frame's sightings (RockSightings) continue the tracks they
// belong to, and each track's ground contact is triangulated from every ray that saw it.
//
// Why: one frame ranges a rock by meeting the ray through its contact with the ground plane under
// the rover. A contact a little above or below that plane (undulating ground, a change of slope)
// moves the rock by dz x range / camera height along the ray: 2 cm at 4 m from a 0.6 m mount is
// 13 cm, more than a small rock's match radius, and the error is the same in every frame from the
// same place. As the rover drives, the ray to the contact turns (steeper as it approaches, sideways
// as it passes): the rays from several places meet at the contact's true position, height and all.
//
// Per track: the normal equations of the point nearest all its rays (sum over frames of
// w (I - d d^T) and w (I - d d^T) o; o = camera centre at the mount height above the ground plane,
// d = unit ray to the contact, world frame), plus a prior that the contact lies on the ground
// plane (std ground_sigma_m). One ray and the prior give the single-frame answer; rays from
// places farther apart pull it to the triangulated one. A ray weighs 1 / sigma^2 with
// sigma = ray_sigma_m + ray_sigma_per_m x range (its angular error at that range).
//
// Association: a sighting continues the track (not yet continued in this frame) whose contact
// lies nearest its ray: across the ray within `gate` x the ray's sigma (+ a quarter of the rock's
// width: the contact seen from another side is another point of its footprint), along it within
// `gate` x the sighting's range sigma; cheapest first. An unmatched sighting opens a track. A
// track unseen for `max_age_frames` frames closes (it is handed over once in closed() and its
// slot is free); when every slot is taken, the one unseen longest closes early.
//
// Centre = contact + the mean footprint radius along the nearest view; height = where the top ray
// of each frame meets the vertical through the centre, relative to the contact, averaged over the
// `kObservations` nearest frames (weight score / range^2); width = their mean width.
// Output: table() (live tracks) and closed() (tracks closed by the last update), world frame, one
// column per track (TrackRow; NaN after the count). No heap allocation after construction.
#include <array>
#include <vector>

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include "regolith/mapping/pose2.hpp"

namespace regolith::mapping {

struct RockTrackerParams {
  bool enabled = true;            ///< false: every sighting is its own one-frame track (ground-plane ranging only)
  int max_tracks = 512;           ///< live tracks at once
  double ground_sigma_m = 0.03;   ///< m, std of a contact's height about the ground plane under the camera
  double ray_sigma_m = 0.02;      ///< m, std of a contact ray across its direction, at 0 m ...
  double ray_sigma_per_m = 0.01;  ///< ... growing by this per m of range (a pixel and the tilt's error)
  double gate = 3.0;              ///< association gate, in standard deviations
  int max_age_frames = 15;        ///< a track unseen for this many frames is closed
  /// rad, error of the camera's tilt against the far ground that every frame of a track shares, for
  /// the reported covariance only (kTrackPosXx..; the ranging tilt's rms against the truth's
  /// large-scale ground plane on the dev drives: 0.007-0.023 rad in pitch, 0.018-0.030 in roll).
  double report_tilt_sigma_rad = 0.02;
  void validate() const;  ///< FieldError("mapping.tracks", ...)
};

/// Rows of RockTracker::table() and closed().
enum TrackRow {
  kTrackX,  ///< m, world: the rock's centre
  kTrackY,
  kTrackHeight,  ///< m, above its contact
  kTrackWidth,   ///< m
  kTrackScore,   ///< summed sighting scores
  kTrackSxx,     ///< m^2, covariance of the centre
  kTrackSxy,
  kTrackSyy,
  kTrackFrames,  ///< frames that saw it
  /// m^2, the covariance of the centre to report (the map's rocks, terrain/world_rocks): the
  /// triangulation's (kTrackSxx..) plus the errors every frame shares, which more frames do not
  /// average out (RockTrackerParams::report_tilt_sigma_rad, ground_sigma_m): along the nearest
  /// frame's view, a tilt error against the far ground ((R^2 + h^2) / h x it, R its range, h the
  /// camera height), the ground's height there (R / h x ground_sigma_m) and a quarter of the
  /// width; across it the sighting's lateral sigma (kSightSigmaLateral: a pixel and a quarter of
  /// the width, as the blob may be the rock's lit half).
  kTrackPosXx,
  kTrackPosXy,
  kTrackPosYy,
  /// The track's number, 1, 2, ... in the order the tracker opened them (since construction or
  /// reset()); a track keeps it until it closes, and the map keeps it with the closed track.
  /// Exact in the float table up to 2^24 tracks.
  kTrackId,
  kTrackRows
};

class RockTracker {
 public:
  static constexpr int kObservations = 8;  ///< frames kept per track for its height (the nearest)

  /// `max_sightings`: the most sightings one frame can bring (RockSightingParams::max_sightings).
  RockTracker(const RockTrackerParams& params, int max_sightings);

  /// One frame's sightings (RockSightings::table()), seen from `camera_foot` (world) by a camera
  /// `mount_height_m` above the ground plane. Returns the number of sightings used. A non-finite
  /// pose or mount height uses none (the frame still ages the tracks).
  int update(const cv::Mat& sightings, const Pose2& camera_foot, double mount_height_m);

  int count() const { return count_; }  ///< live tracks (columns of table())
  const cv::Mat& table() const { return table_; }
  int closed_count() const { return closed_count_; }  ///< tracks closed by the last update
  const cv::Mat& closed() const { return closed_; }
  long opened() const { return opened_; }  ///< tracks opened since construction (or reset())
  void reset();

 private:
  struct Observation {
    double ox = 0, oy = 0;        // camera centre (world)
    double slope = 0;             // tan of the top ray's angle
    double weight = 0;            // score / range^2; 0 = empty
    double range = 0, width = 0;  // m, of the sighting
    double sigma_lateral = 0;     // m, across its view (a pixel, and which part of the rock the blob is)
  };
  struct Track {
    Eigen::Matrix3d a;
    Eigen::Vector3d b, p;  // normal equations and their solution (the contact)
    double score = 0, width_sum = 0, radius_sum = 0, weight_sum = 0, height_m = 0;
    double mount_m = 0;
    int frames = 0;  // 0 = free slot
    long id = 0;     // opened_ when it opened: kTrackId
    long last = 0;   // frame counter of the last sighting
    std::array<Observation, kObservations> obs;
  };
  struct Ray {
    Eigen::Vector3d o, d;  // camera centre, unit ray to the contact (world)
    double ground = 0;     // distance from o to the ray's ground point
    double sigma = 0, sigma_along = 0, spread = 0, range = 0, radius = 0;
    bool ok = false;  // finite: usable
  };
  void write(const Track& t, cv::Mat& table, int column) const;
  void close(int slot);
  int free_slot();
  void add(Track& t, const Ray& r, const cv::Mat& sightings, int k);
  RockTrackerParams p_;
  int max_sightings_ = 0;
  std::vector<Track> tracks_;
  std::vector<Ray> rays_;
  std::vector<int> matched_;                       // per sighting: track slot or -1
  std::vector<unsigned char> taken_;               // per slot: continued this frame
  std::vector<std::array<double, 3>> candidates_;  // (cost, sighting, slot)
  cv::Mat table_, closed_;
  int count_ = 0, closed_count_ = 0;
  long frame_ = 0, opened_ = 0;
};

}  // namespace regolith::mapping
