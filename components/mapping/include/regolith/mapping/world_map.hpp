#pragma once
// A terrain map in a fixed world (odometry) frame that improves as the rover drives.
//
// Grid: cell (row i, column j) is centred at x = origin_x + j * res, y = origin_y + i * res
// (rows along +y, row 0 = smallest y; columns along +x; the convention of `regolith map`'s
// map.json). The window can follow the rover (recenter: whole-cell shifts, no allocation).
//
// Fusion (per frame): each cell of a body-frame terrain grid (traversability's GridMap:
// elevation + confidence, in the camera's ground frame) is looked up from every world cell its
// footprint covers (inverse mapping: no holes) and merged into a running weighted mean and
// variance, weight = confidence x 1 / (1 + (range / range_scale)^2) (nearer and better resolved
// = more weight; each extra look adds weight). Layers (CV_32F, NaN = never seen):
//   elevation (m), elevation_variance (m^2), confidence (0..1 = 1 - exp(-weight / weight_full)),
//   observed_count (frames), traversability and its parts, relief (elevation above the smoothed
//   local ground), shadow_height (heights of objects measured from their cast shadows, spread
//   over shadow_spread_m around their feet), hazard (0..1: the probability of an obstacle of
//   hazard_height_m, a noisy-OR of the sightings, the shadow heights and, weakly and in
//   proportion to the cell's confidence, the relief;
//   NaN where no cue covers the cell: a cell seen with less than hazard_min_weight has no relief),
//   rock_evidence (summed scores of the rocks tracked across frames, spread over their position's uncertainty)
//   and rock_height (their weighted mean height, where the evidence reaches rock_min_evidence).
// Rocks: the tracks handed over by fuse_rock_tracks (closed ones kept, at most max_rocks, live
// ones replaced each frame) with enough frames, evidence and height, one per rock_merge_m; with
// rocks_from_relief also connected relief blobs. Derived layers (finish()) and rocks are computed
// on request.
#include <string>
#include <string_view>
#include <vector>

#include <opencv2/core.hpp>

#include "regolith/mapping/pose2.hpp"
#include "regolith/traversability/traversability.hpp"

namespace regolith::mapping {

struct WorldMapParams {
  double resolution_m = 0.04;  ///< m per cell
  double length_x_m = 16.0;    ///< m, window extent along world x
  double length_y_m = 16.0;    ///< m, window extent along world y
  double range_scale_m = 2.0;  ///< m, a look from this range weighs half a look from 0 m
  double max_range_m = 5.0;    ///< m, body cells farther than this are not fused
  double weight_full = 1.0;    ///< weight at which confidence reaches 1 - 1/e
  double min_weight = 0.01;    ///< cells with less total weight stay unknown (elevation)
  /// Weight a cell's relief needs to shape the local ground and to be a hazard cue: below it a
  /// cell has an elevation (and its variance) but its relief is unknown (NaN).
  double hazard_min_weight = 0.05;
  double observation_sigma_m = 0.02;  ///< m, std of one look (floor of elevation_variance)
  double robust_sigma_m = 0.03;       ///< m, looks this far from a well-seen cell's mean weigh half (0 = plain mean)
  double fill_radius_m = 0.0;         ///< m, holes this close to observed cells are interpolated (0 = off)
  /// m, half-side of the square over which each known cell's elevation is the median of the known
  /// cells' fused means (what the layers and everything derived from them show; the fused means
  /// themselves are kept): one look's mismatch at a cell does not stand out of its neighbours.
  /// Rounded to whole cells, at most 3 (a finer map gets a 7 x 7 window); 0 = off. Default: one
  /// cell at 4 cm (a 3 x 3 median).
  double elevation_median_m = 0.04;
  /// m, standard deviation of the Gaussian over which the hazard of the known cells is averaged
  /// (normalised over the known cells, kernel cut at 2 sigma; unknown cells stay unknown): where a
  /// cue put an obstacle is uncertain by about a cell. At most 4 cells (a finer map gets 4); 0 = off.
  double hazard_blur_m = 0.04;
  double fill_min_weight = 0.05;  ///< smoothed confidence a hole needs to be filled
  double ground_sigma_m = 0.25;   ///< m, scale of the smoothed local ground (relief = elevation - ground)
  double hazard_height_m = 0.10;  ///< m, obstacle height the hazard is the probability of
  double hazard_relief_weight =
      0.2;  ///< probability the parallax relief alone carries at hazard_height_m and full confidence (a weak cue)
  double hazard_evidence_scale = 1.0;  ///< summed sighting scores at which p(sighted rock) = 1 - 1/e
  double shadow_spread_m = 0.08;       ///< m, a caster's height covers cells this close to its foot
  double rock_min_height_m = 0.05;     ///< m, relief a rock must reach
  double rock_min_area_m2 = 0.004;     ///< m^2, smallest rock footprint reported
  double sighting_radius_m = 0.06;     ///< m, standard deviation at which a sighting adds its full score at its centre
  double rock_min_evidence = 1.0;      ///< summed sighting scores a rock needs (several frames agreeing)
  int rock_min_frames = 3;             ///< frames a tracked rock must have been sighted in
  int max_rocks = 4096;                ///< rock tracks the map keeps (the weakest go first)
  double rock_merge_m = 0.25;          ///< m, rocks closer than this are one rock (the stronger kept)
  bool rocks_from_relief =
      false;  ///< also report connected relief blobs as rocks (off: more false than true rocks on the dev drives)
  double rock_min_confidence = 0.3;  ///< confidence a rock's top cell needs (0 = any; a shadow-only top has none)
  traversability::TraversabilityParams traversability;  ///< slope / step / roughness thresholds
  /// Throws FieldError("mapping.map", field, ...) naming the bad field.
  void validate() const;
};

struct MapRock {
  double x_m = 0.0, y_m = 0.0;  ///< world position (a tracked rock's centre; a relief rock's highest cell)
  double height_m = 0.0;        ///< above its ground
  double width_m = 0.0;         ///< footprint diameter
  double score = 0.0;           ///< 0..1
  /// Covariance of (x_m, y_m), m^2: a tracked rock's from the triangulation of its contact (the
  /// rays and the ground prior, RockTracker); a relief rock's (resolution / 2)^2.
  double cov_xx = 0.0, cov_xy = 0.0, cov_yy = 0.0;
  /// A tracked rock's track number (kTrackId): the same rock keeps it from map update to map update.
  /// Where several tracks (or a relief rock) hold one place (closer than rock_merge_m) the strongest
  /// gives the position and the oldest track its number, so a rock lost for
  /// RockTrackerParams::max_age_frames and seen again by a new track keeps the number it was first
  /// reported with. 0 for a relief rock no track holds (no identity across updates).
  long id = 0;
};

class WorldMap {
 public:
  /// Window centred on (center_x, center_y); allocates every layer and scratch buffer.
  WorldMap(const WorldMapParams& params, double center_x_m, double center_y_m);

  const WorldMapParams& params() const { return p_; }
  int rows() const { return rows_; }
  int cols() const { return cols_; }
  double origin_x() const { return ox_; }  ///< centre of cell (0, 0)
  double origin_y() const { return oy_; }
  double resolution() const { return p_.resolution_m; }
  cv::Point2d cell_center(int i, int j) const { return {ox_ + j * p_.resolution_m, oy_ + i * p_.resolution_m}; }

  /// Layer names in layer() order.
  static const std::vector<std::string>& layer_names();
  const cv::Mat& layer(std::string_view name) const;

  /// Keeps (x, y) (the rover) at least `margin_m` inside the window: when it is farther than
  /// length / 2 - margin from the centre along an axis, the window is re-centred on it (whole
  /// cells). Cells leaving the window are forgotten. No heap allocation.
  void recenter(double x_m, double y_m, double margin_m);

  /// Fuses one body-frame grid (elevation + confidence layers) seen from `camera_foot` (the
  /// grid's frame in the world). No heap allocation. Returns the number of cells updated.
  int fuse(const traversability::GridMap& body, const Pose2& camera_foot, double weight = 1.0);

  /// Fuses scattered height samples: (x, y) in the frame `camera_foot` places in the world, z up
  /// (m), weight w (> 0; NaN z or w <= 0 skipped); all CV_32F of one size. Each sample goes to
  /// its nearest world cell with weight w / (1 + (range / range_scale)^2). No heap allocation.
  int fuse_points(const cv::Mat& x, const cv::Mat& y, const cv::Mat& z, const cv::Mat& w, const Pose2& camera_foot);

  /// Fuses object heights measured from cast shadows at the objects' feet (ShadowCue): a running
  /// weighted mean per cell, kept apart from the elevation (a caster height is the height of
  /// what stands there, not of the ground). No heap allocation.
  int fuse_casters(const cv::Mat& x, const cv::Mat& y, const cv::Mat& h, const cv::Mat& w, const Pose2& camera_foot);

  /// Rocks followed across frames (RockTracker): `closed` tracks (RockTracker::closed(), TrackRow
  /// columns up to `n`) are added to the rock evidence for good; `live` ones (RockTracker::table())
  /// replace the previous call's live evidence (their estimates still move). Each track adds its
  /// summed score x a Gaussian of its centre's covariance (+ a quarter of its width, at least
  /// sighting_radius_m / 2 per axis; scaled so a track as sharp as sighting_radius_m adds its full
  /// score at its centre, a vaguer one proportionally less), and its height to the
  /// weighted mean of rock_height (widths come with rocks()). No heap allocation.
  void fuse_rock_tracks(const cv::Mat& closed, int n_closed, const cv::Mat& live, int n_live);

  /// Recomputes elevation, variance, confidence, traversability, relief and hazard from the
  /// accumulators. No heap allocation after the first call.
  void finish();
  /// The map's rocks, strongest first (call finish() first): the tracked rocks with enough frames,
  /// evidence and height inside the window (and connected relief blobs with rocks_from_relief),
  /// one per rock_merge_m. Allocates (for offline use and reports).
  std::vector<MapRock> rocks() const;
  /// The same into `out` (cleared first). No heap allocation when `out`'s capacity is at least
  /// max_rock_candidates() and rocks_from_relief is off (the relief blobs allocate). Returns out.size().
  std::size_t rocks(std::vector<MapRock>& out) const;
  /// Most rocks rocks() can consider at once (every closed and live track the map holds).
  std::size_t max_rock_candidates() const { return static_cast<std::size_t>(tracks_.cols); }

 private:
  void add(int i, int j, double z, double w);
  std::vector<MapRock> relief_rocks() const;
  void smooth_known(const cv::Mat& src, const cv::Mat& w, cv::Mat& dst, double sigma_cells);
  // elevation_median_m: the known cells' median over their neighbourhood (written back to the layer).
  void median_of_known(cv::Mat& el);
  // hazard_blur_m: the known cells' hazard averaged with Gaussian weights (in place).
  void blur_known(cv::Mat& hazard);
  WorldMapParams p_;
  int rows_ = 0, cols_ = 0;
  double ox_ = 0.0, oy_ = 0.0;
  cv::Mat wsum_, mean_, m2_, count_;  // accumulators (CV_64F weight/mean/m2, CV_32F count)
  cv::Mat shadow_w_, shadow_h_;       // caster heights from shadows: weight, weighted mean (CV_32F)
  void paint_tracks(const cv::Mat& t, int n, cv::Mat& w, cv::Mat& h);
  float evidence(int i, int j) const { return sight_w_.at<float>(i, j) + live_w_.at<float>(i, j); }
  float evidence_height(int i, int j) const { return sight_h_.at<float>(i, j) + live_h_.at<float>(i, j); }
  cv::Mat sight_w_, sight_h_;  // closed rock tracks: evidence and its weighted sum of heights (CV_32F)
  cv::Mat live_w_, live_h_;    // the same for the live tracks (repainted every frame)
  cv::Mat tracks_;             // TrackRow columns: closed tracks [0, n_closed_), then the live ones
  int n_closed_ = 0, n_live_ = 0;
  std::vector<cv::Mat> layers_;
  traversability::GridMap trav_;            // view of elevation for compute_layers
  traversability::LayerWorkspace trav_ws_;  // compute_layers' scratch, reused every frame
  cv::Mat scratch_, scratch2_, scratch3_, mask_;
  cv::Mat ground_w_;  // confidence of the cells the local ground is smoothed from
  cv::Mat fill_w_;    // fill_radius_m: how near each hole is to seen cells (smoothed confidence; 0 where known)
  std::vector<double> line_, line_w_;
};

}  // namespace regolith::mapping
