// Component "sams": shared DTM ("terrain/dtm") -> saliency -> boxes -> direct-depth ranging ->
// "terrain/rocks" (channel + regolith_msgs/RockArray) and a rock-probability grid layer
// ("terrain/rock_probability"). Every buffer is sized in configure() by a warm-up frame.
#include "regolith/saliency/component.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "regolith/common/camera.hpp"
#include "regolith/common/grid_params.hpp"
#include "regolith/common/payloads.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/direct_depth/direct_depth.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/worker_pool.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/model_file.hpp"
#include "regolith/saliency/peers.hpp"
#include "regolith/saliency/trained.hpp"

namespace regolith::saliency {
namespace {

using RockArrayMsg = msgs::regolith_msgs::RockArray;
constexpr std::size_t kIdCapacity = 8;
constexpr std::size_t kStringCapacity = 32;
// A camera smaller than the pyramid is processed enlarged; past this many pixels (2048x2048) the
// camera is a sliver the pyramid does not suit, refused at configure rather than gigabytes of buffers.
constexpr double kMaxEnlargedPixels = 4194304.0;

/// An image region as its runs of pixels along each row, made once from a mask at configure: the
/// region's mean and the filling of everything outside it cost a pass over runs, not a
/// per-pixel test of the mask (on a 640x480 frame the masked cv::mean and fill were ~10 % of SAMS).
class RegionRuns {
 public:
  void build(const cv::Mat& mask) {
    size_ = mask.size();
    runs_.clear();
    count_ = 0;
    for (int r = 0; r < mask.rows; ++r) {
      const uchar* m = mask.ptr<uchar>(r);
      for (int c = 0; c < mask.cols;) {
        if (m[c] == 0) {
          ++c;
          continue;
        }
        const int c0 = c;
        while (c < mask.cols && m[c] != 0) ++c;
        runs_.push_back({r, c0, c});
        count_ += c - c0;
      }
    }
  }
  /// Mean of `m` (one channel, the mask's size) over the region: integer sums for 8-bit images,
  /// double for float ones, as cv::mean with the mask.
  template <typename T>
  double mean(const cv::Mat& m) const {
    using Acc = std::conditional_t<std::is_integral_v<T>, std::int64_t, double>;
    Acc sum = 0;
    for (const Run& run : runs_) {
      const T* p = m.ptr<T>(run.row);
      Acc s = 0;
      for (int c = run.begin; c < run.end; ++c) s += static_cast<Acc>(p[c]);
      sum += s;
    }
    return count_ > 0 ? static_cast<double>(sum) / static_cast<double>(count_) : 0.0;
  }

  /// Every pixel of `m` outside the region := v.
  template <typename T>
  void fill_outside(cv::Mat& m, T v) const {
    int row = 0, col = 0;  // the first pixel not yet visited
    auto fill_to = [&](int r, int c) {
      for (; row < r; ++row, col = 0) std::fill(m.ptr<T>(row) + col, m.ptr<T>(row) + size_.width, v);
      std::fill(m.ptr<T>(row) + col, m.ptr<T>(row) + c, v);
    };
    for (const Run& run : runs_) {
      fill_to(run.row, run.begin);
      col = run.end;
    }
    if (row < size_.height) fill_to(size_.height - 1, size_.width);
  }

 private:
  struct Run {
    int row, begin, end;  // pixels [begin, end) of the row
  };
  cv::Size size_;
  std::vector<Run> runs_;
  std::size_t count_ = 0;
};

class SamsComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    method_name_ =
        p.get<std::string>("method", "sams",
                           {.choices = {"sams", "itti", "spectral_residual", "fine_grained", "trained"},
                            .doc = "saliency method (sams = Itti + SfS structure channel; trained = contrast "
                                   "candidates ranked by the trained rock model, `model`)"});
    trained_ = method_name_ == "trained";
    method_ = trained_ ? Method::kContrast : method_from_string(method_name_);
    const IttiParams ip = read_saliency_model(p);
    const PostProcessParams pp = read_post_processing(p);

    // ---- ranging ----
    ranging_.hazard_size_m = p.get<double>(
        "hazard_size_m", ranging_.hazard_size_m,
        {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "a rock wider or higher than this is a hazard"});
    // The camera whose DTM frames this reads (its calibration and mount: rover.cameras.<camera>).
    p.reject_moved("camera_model",
                   "the camera is described once, in rover.cameras.<camera> {camera_info, mount}; "
                   "write `camera: <device>` here");
    const RoverCamera& rover_camera = ctx.rover_camera(p, "camera");
    const direct_depth::CameraModel model = common::camera_model_of(rover_camera);
    const int w = model.width, h = model.height;
    size_ = cv::Size(w, h);
    if (trained_) load_trained_model(p);
    // SAMS and Itti build a pyramid of 2^(centre_max + delta_max) px a side: a smaller camera's
    // frames (a 320x240 navigation camera) are processed enlarged, as `regolith rocks` does.
    input_size_ = size_;
    if (method_ == Method::kSams || method_ == Method::kItti) {
      try {
        input_size_ = ip.input_size(size_, kMaxEnlargedPixels);
      } catch (const std::invalid_argument& e) {
        p.fail("delta_max", std::string(e.what()) + ": lower centre_max or delta_max");
      }
    }

    // ---- grid layer (traversability grid geometry) ----
    grid_ =
        common::read_grid_geometry(p, {0.05, 4.0, 4.0, 3.0, 0.0}, "rock_probability grid (= the traversability grid)");
    max_range_m_ =
        p.get<double>("max_range_m", 10.0,
                      {.unit = "m",
                       .min = 0.0,
                       .min_exclusive = true,
                       .doc = "pixels farther than this flat-ground range (and above the horizon) are not searched"});
    const std::string frame_id =
        p.get<std::string>("frame_id", rover_camera.frame_id,
                           {.doc = "header.frame_id of terrain/rocks (image-space boxes; default the camera's optical "
                                   "frame, rover.cameras.<camera>.frame_id)"});
    const double timeout_s = p.get<double>(
        "input_timeout_s", 2.0,
        {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = "the DTM input is stale after this long"});
    const int nx = grid_.size_x(), ny = grid_.size_y();
    if (static_cast<long>(nx) * ny > 4'000'000L) p.fail("resolution_m", "grid has more than 4e6 cells");

    // SAMS / Itti: the channels (intensity, 4 orientations, structure) as parallel jobs
    workers_ = runtime::workers_from(p, name().empty() ? std::string("sams") : name());
    use_workers(workers_.get());
    try {
      depth_ = std::make_unique<direct_depth::DirectDepth>(model);
      itti_ = std::make_unique<IttiSaliency>(ip);
      itti_->set_parallel(workers_.get());
      detector_ = std::make_unique<BoxDetector>(pp);
      if (method_ == Method::kSpectralResidual || method_ == Method::kFineGrained)
        peer_ = std::make_unique<OpenCvSaliency>(method_);
    } catch (const std::invalid_argument& e) {
      p.fail({}, e.what());
    }
    const direct_depth::DirectDepth* dd = depth_.get();
    ranger_ = [dd](double u, double v) -> std::optional<GroundPoint> {
      // range_rock: pixel centres at +0.5; direct_depth: pixel centres at integers.
      const direct_depth::GroundPoint g = dd->ground(u - 0.5, v - 0.5);
      if (!g.valid) return std::nullopt;
      return GroundPoint{g.range_m, g.lateral_m};
    };

    build_lookups(p);
    build_enlargement();
    warm_up();
    connect(p, ctx, frame_id, timeout_s);
  }

  // ---- configure()'s stages ----
 private:
  // The saliency model (Itti / SAMS): normalisation, structure feature, pyramid levels, weights.
  IttiParams read_saliency_model(Params& p) {
    IttiParams ip;
    ip.normalisation = Normalisation::kLocalMax;
    const std::string norm = p.get<std::string>(
        "normalisation", "local_max",
        {.choices = {"local_max", "iterative"}, .doc = "N(.) operator: Itti 1998 local-max or iterative DoG"});
    ip.normalisation = norm == "iterative" ? Normalisation::kIterative : Normalisation::kLocalMax;
    const std::string feat = p.get<std::string>(
        "structure", "height", {.choices = {"height", "slope"}, .doc = "SAMS structure feature of the DTM"});
    ip.structure_feature = feat == "slope" ? StructureFeature::kSlope : StructureFeature::kHeight;
    ip.centre_min = p.get<int>("centre_min", ip.centre_min, {.min = 0, .max = 10, .doc = "finest centre level c"});
    ip.centre_max = p.get<int>("centre_max", ip.centre_max, {.min = 0, .max = 10, .doc = "coarsest centre level c"});
    ip.delta_min =
        p.get<int>("delta_min", ip.delta_min, {.min = 1, .max = 10, .doc = "smallest surround offset s - c"});
    ip.delta_max = p.get<int>("delta_max", ip.delta_max, {.min = 1, .max = 10, .doc = "largest surround offset s - c"});
    ip.map_level =
        p.get<int>("map_level", ip.map_level, {.min = 0, .max = 12, .doc = "pyramid level of the maps (4 = 1:16)"});
    ip.weights.intensity =
        p.get<double>("w_intensity", 0.2, {.min = 0.0, .doc = "SAMS weight of the intensity channel"});
    ip.weights.orientation =
        p.get<double>("w_orientation", 0.5, {.min = 0.0, .doc = "SAMS weight of the orientation channel"});
    ip.weights.structure =
        p.get<double>("w_structure", 0.3, {.min = 0.0, .doc = "SAMS weight of the structure (DTM) channel"});
    ip.weights.colour = 0.0;  // the DTM carries a grey image
    if (method_ == Method::kItti) ip.weights = {1.0, 1.0, 0.0, 0.0};
    try {
      ip.validate();
    } catch (const FieldError& e) {
      if (e.owner() == "ChannelWeights") p.fail("w_" + e.field(), e.problem());  // read from w_<channel>
      p.fail(e);
    }
    if (method_ == Method::kSams && ip.weights.intensity + ip.weights.orientation + ip.weights.structure <= 0.0)
      p.fail("w_structure", "all SAMS channel weights are 0");

    return ip;
  }

  // The binary map -> boxes step: threshold, morphology, smallest component, most boxes.
  PostProcessParams read_post_processing(Params& p) {
    PostProcessParams pp;
    pp.threshold_scale = p.get<double>("threshold_scale", pp.threshold_scale,
                                       {.min = 0.0, .min_exclusive = true, .doc = "binary threshold = scale x Otsu"});
    pp.open_radius = p.get<int>("open_radius_px", pp.open_radius,
                                {.unit = "px", .min = 0, .max = 50, .doc = "morphological opening radius (0 = none)"});
    pp.close_radius = p.get<int>("close_radius_px", pp.close_radius,
                                 {.unit = "px", .min = 0, .max = 50, .doc = "morphological closing radius (0 = none)"});
    pp.min_area =
        p.get<int>("min_area_px", pp.min_area, {.unit = "px", .min = 1, .doc = "smallest connected component kept"});
    pp.max_detections =
        p.get<int>("max_detections", 32,
                   {.min = 1, .max = static_cast<double>(kMaxRocks), .doc = "rocks kept per frame (highest scores)"});
    max_detections_ = pp.max_detections;
    try {
      pp.validate();
    } catch (const std::invalid_argument& e) {
      p.fail({}, e.what());
    }

    return pp;
  }

  // Method trained: the rock model file, its score threshold and NMS overlap, and the candidate
  // buffers reserved for the most candidates a frame can give.
  void load_trained_model(Params& p) {
    const std::string path = p.get<std::string>(
        "model", default_trained_model_path(),
        {.doc = "rock model file of method trained (`regolith train rocks`; default the shipped model)"});
    try {
      model_ = saliency::load_trained_model(path);
    } catch (const ModelError& e) {
      p.fail("model", e.what());
    }
    // The model's BoxParams, each overridable here.
    BoxParams& box = model_.box;
    box.score_threshold =
        p.get<double>("score_threshold", box.score_threshold,
                      {.min = 0.0, .max = 1.0, .doc = "method trained: lowest box score kept (default the model's)"});
    box.nms_iou = p.get<double>("nms_iou", box.nms_iou,
                                {.min = 0.0,
                                 .max = 1.0,
                                 .min_exclusive = true,
                                 .doc = "method trained: a box overlapping a better one by more than this IoU is "
                                        "dropped (default the model's)"});
    box.refine_fraction = p.get<double>(
        "box_refine_fraction", box.refine_fraction,
        {.min = 0.0,
         .max = 0.99,
         .doc = "method trained: each kept box shrunk to the strongest part of the saliency map inside it at this "
                "fraction of its peak; 0 keeps the boxes as selected (default the model's)"});
    box.crowd.count = p.get<int>(
        "crowd_count", box.crowd.count,
        {.min = 0.0,
         .max = 1000.0,
         .doc = "method trained: a frame with at least this many boxes at or above score_threshold is a rock field "
                "and keeps its boxes down to crowd_score_threshold as well; 0 = no such rule (default the model's)"});
    box.crowd.threshold =
        p.get<double>("crowd_score_threshold", box.crowd.threshold,
                      {.min = 0.0,
                       .max = 1.0,
                       .doc = "method trained: lowest box score a rock-field frame keeps (default the model's)"});
    map_options_.guide_radius_px = p.get<int>(
        "map_guide_radius_px", model_.map_guide_radius_px(size_.width),
        {.min = 0.0,
         .max = 256.0,
         .doc = "method trained: window radius of the guided filter the saliency map goes through, smoothing it "
                "inside the image's even regions and keeping its steps at the image's edges "
                "(TrainedModel::guide_map; default 12 px at the model's working width, in proportion to the "
                "camera's width); the pixel stage's grid goes through the same filter; 0: no filter (the painted "
                "map goes on as it is, the stage's grid is only interpolated back)"});
    map_options_.guide_eps = p.get<double>(
        "map_guide_eps", TrainedModel::kMapGuideEps,
        {.min = 0.0,
         .min_exclusive = true,
         .doc = "method trained: the guided filter's ridge on the intensity gain (intensity in 0..1): larger "
                "smooths across weaker edges"});
    map_options_.pixel_stage =
        p.get<bool>("pixel_stage", true,
                    {.doc = "method trained: the map's last step, the model's pixel forest (each cell of a grid a "
                            "quarter of the model's working width scored from the map and the image around it; "
                            "a model without one publishes the guided map)"}) &&
        model_.has_pixel_stage();
    extractor_ = std::make_unique<CandidateExtractor>(model_.candidates);
    const std::size_t most = extractor_->max_candidates(size_);
    candidates_.candidates.reserve(most);
    scores_.reserve(most);
    box_scratch_.reserve(size_, most);
  }

  // The image region searched (pixels that see the flat ground within max_range_m, at full and at
  // quarter resolution), the work images, and each grid cell's pixel.
  void build_lookups(Params& p) {
    const direct_depth::DirectDepth* dd = depth_.get();
    const int w = size_.width, h = size_.height, nx = grid_.size_x(), ny = grid_.size_y();
    // Region searched: pixels that see the flat ground within max_range_m. The rest (sky, far
    // terrain) is filled with the mean of the region before saliency, and zeroed afterwards.
    roi_ = (dd->valid_map() != 0) & (dd->range_map() <= max_range_m_);
    if (cv::countNonZero(roi_) == 0) p.fail("max_range_m", "no pixel of the image sees the ground within max_range_m");
    work_gray_.create(size_, CV_8U);
    work_height_.create(size_, CV_32F);
    // The sfs component's quarter-resolution solve (DtmFrame::height4, floor(frame / 4) a side)
    // enters the structure pyramid at level 2 (ceil-halved twice: one more row / column when a
    // side is not a multiple of 4, copied from the edge); its searched region: the block centres'.
    const cv::Size s4 = IttiSaliency::level_size(size_, 2);
    work_height4_.create(s4, CV_32F);
    roi4_.create(s4, CV_8U);
    for (int r = 0; r < s4.height; ++r)
      for (int c = 0; c < s4.width; ++c)
        roi4_.at<uchar>(r, c) = roi_.at<uchar>(std::min(4 * r + 2, h - 1), std::min(4 * c + 2, w - 1));
    roi_runs_.build(roi_);
    roi4_runs_.build(roi4_);

    // Cell -> pixel lookup (flat ground), -1 = not visible.
    cell_pixel_.create(nx, ny, CV_32S);
    for (int i = 0; i < nx; ++i)
      for (int j = 0; j < ny; ++j) {
        const cv::Point2d cell = grid_.cell_center(i, j);
        const double x = cell.x, y = cell.y;
        int idx = -1;
        if (x > 0.0) {
          if (const auto px = dd->project(x, y)) {
            const int c = static_cast<int>(std::lround(px->x)), r = static_cast<int>(std::lround(px->y));
            if (c >= 0 && r >= 0 && c < w && r < h && roi_.at<uchar>(r, c) != 0) idx = r * w + c;
          }
        }
        cell_pixel_.at<int>(i, j) = idx;
      }
  }

  // A camera smaller than the pyramid: the resampling tables between its frames (full and quarter
  // resolution) and the enlarged frames the saliency model reads, and back for the map.
  void build_enlargement() {
    if (input_size_ == size_) return;
    using Mode = ResizeTable::Mode;
    up_gray_.build(size_, input_size_, Mode::kLinear);
    up_height4_.build(IttiSaliency::level_size(size_, 2), IttiSaliency::level_size(input_size_, 2), Mode::kLinear);
    down_.build(input_size_, size_, Mode::kArea);
    gray_f_.create(size_, CV_32F);
    for (cv::Mat* m : {&big_gray_, &big_height_, &big_saliency_}) m->create(input_size_, CV_32F);
    big_height4_.create(IttiSaliency::level_size(input_size_, 2), CV_32F);
  }

  // Warm-up on a synthetic frame of the camera's size: sizes every buffer of the models.
  void warm_up() {
    const int w = size_.width, h = size_.height;
    cv::Mat gray(size_, CV_8U), height(size_, CV_32F);
    for (int r = 0; r < h; ++r)
      for (int c = 0; c < w; ++c) {
        const double d = std::hypot(c - 0.5 * w, r - 0.6 * h);
        gray.at<uchar>(r, c) = static_cast<uchar>(110 + (d < 0.1 * w ? 80 : 0) + 20 * std::sin(0.11 * c));
        height.at<float>(r, c) = static_cast<float>(d < 0.1 * w ? 3.0 : 0.0);
      }
    // BoxDetector appends every component before truncating; the trained method keeps every
    // candidate that survives NMS
    dets_.reserve(std::max<std::size_t>(kMaxRocks + 1024, candidates_.candidates.capacity()));
    saliency_.create(size_, CV_32F);
    cv::Mat height4(size_.height / 4, size_.width / 4, CV_32F);
    for (int r = 0; r < height4.rows; ++r)
      for (int c = 0; c < height4.cols; ++c) height4.at<float>(r, c) = height.at<float>(4 * r + 2, 4 * c + 2);
    quarter_ok_ = itti_ && itti_->params().centre_min >= 2;  // level 2 feeds no centre below it
    for (int k = 0; k < 2; ++k) {
      process(gray, height, 0);
      if (quarter_ok_) process(gray, height4, 2);
    }
  }

  // The DTM input, the rock and rock-probability channels, and the terrain/rocks DDS writer.
  void connect(Params& p, runtime::Context& ctx, const std::string& frame_id, double timeout_s) {
    const int nx = grid_.size_x(), ny = grid_.size_y();
    dtm_ = &ctx.consume<common::DtmFrame>(common::kDtmChannel);
    // Only SAMS proper reads the DTM's heights (its terrain-structure channel); the other methods
    // read the grey image.
    // The structure channel reads the heights from pyramid level 2 on: a quarter-resolution solve serves.
    if (method_ == Method::kSams && !trained_ && !peer_)
      ctx.want(common::kDtmChannel, quarter_ok_ ? common::kDtmHeightQuarter : common::kDtmHeight);
    rocks_out_ = &ctx.produce<RockFrame>(kRocksChannel, 4);
    const common::GridGeometry grid = grid_;
    prob_out_ = &ctx.produce<RockProbabilityFrame>(kRockProbabilityChannel, 4, [grid, nx, ny] {
      RockProbabilityFrame f;
      static_cast<common::GridGeometry&>(f) = grid;
      f.probability.create(nx, ny, CV_32F);
      f.probability.setTo(std::numeric_limits<float>::quiet_NaN());
      return f;
    });
    input_ = &watch_input("dtm", from_seconds(timeout_s));

    if (dds::Participant* part = ctx.dds()) {
      const dds::TopicInfo* info = dds::find_topic(kRocksChannel);
      if (info == nullptr) p.fail({}, "DDS topic terrain/rocks is unknown to this build");
      msg_ = part->make_outbox<RockArrayMsg>(
          kRocksChannel, info->writer_qos(), dds::OutboxOptions{dds::OutboxMode::kFifo, 4},
          [&frame_id](RockArrayMsg& m) {
            dds::reserve(m, dds::RockArrayCapacity{kMaxRocks, 1, kStringCapacity, kStringCapacity});
            dds::copy_string(m.header.frame_id, kStringCapacity, frame_id);
            for (std::uint32_t i = 0; i < kMaxRocks; ++i) {
              auto& d = m.detections._buffer[i];
              dds::copy_string(d.header.frame_id, kStringCapacity, frame_id);
              dds::set_length(d.results, 1);
              dds::copy_string(d.results._buffer[0].hypothesis.class_id, kStringCapacity, "rock");
              dds::format_int(d.id, kIdCapacity, static_cast<std::int64_t>(i));
            }
          });
    }
  }

 public:
  void step(const runtime::CycleInfo& c) override {
    auto lease = dtm_->acquire();
    if (!lease) return;
    const common::DtmFrame& d = *lease;
    if (!new_dtm_(lease.generation())) return;
    input_updated(*input_, c.now);
    const bool quarter = d.height_level == 2;
    const cv::Mat& height = quarter ? d.height4 : d.height;
    if (d.gray.size() != size_ || d.gray.type() != CV_8UC1 ||
        height.size() != (quarter ? cv::Size(size_.width / 4, size_.height / 4) : size_)) {
      count_error();
      set_status("DTM size differs from the camera calibration (rover.cameras)");
      return;
    }
    // Size and type are checked above: the saliency pipeline neither throws nor allocates here.
    process(d.gray, height, quarter ? 2 : 0);
    publish(d.stamp, d.sequence);
    set_status("ok");
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("method", method_name_);
    kv.emplace_back("rocks_last_frame", std::to_string(last_.count));
    kv.emplace_back("hazards_last_frame", std::to_string(last_.hazards));
  }

  std::string result() const override {
    const auto l = rocks_out_ != nullptr ? rocks_out_->acquire() : decltype(rocks_out_->acquire()){};
    if (!l) return {};
    double nearest = -1.0;
    for (std::uint32_t i = 0; i < l->count; ++i)
      if (l->rocks[i].ranged && (nearest < 0.0 || l->rocks[i].range_m < nearest)) nearest = l->rocks[i].range_m;
    char buf[96];
    if (nearest >= 0.0)
      std::snprintf(buf, sizeof buf, "rocks %u, nearest %.1f m, %u hazard%s", l->count, nearest, l->hazards,
                    l->hazards == 1 ? "" : "s");
    else
      std::snprintf(buf, sizeof buf, "rocks %u, %u hazards", l->count, l->hazards);
    return buf;
  }

 private:
  /// work_height4_ := h4 (floor(frame / 4) a side), its last column / row repeated to fill the
  /// pyramid level's size.
  void pad_quarter(const cv::Mat& h4) {
    cv::Mat& o = work_height4_;
    for (int r = 0; r < o.rows; ++r) {
      const float* a = h4.ptr<float>(std::min(r, h4.rows - 1));
      float* b = o.ptr<float>(r);
      for (int c = 0; c < o.cols; ++c) b[c] = a[std::min(c, h4.cols - 1)];
    }
  }

  /// `height`: the frame's size (level 0) or the quarter solve's (level 2, DtmFrame::height4).
  void process(const cv::Mat& gray, const cv::Mat& height, int level) {
    gray.copyTo(work_gray_);
    roi_runs_.fill_outside(work_gray_, cv::saturate_cast<uchar>(roi_runs_.mean<uchar>(gray)));
    if (trained_) {
      // Candidates -> forest scores -> NMS; the pixel score map is the saliency layer.
      extractor_->extract(work_gray_, candidates_);
      model_.score(candidates_, scores_);
      TrainedModel::score_map(candidates_, scores_, saliency_, score_spans_);
      roi_runs_.fill_outside(saliency_, 0.f);
      // refined on the map it publishes
      TrainedModel::boxes(candidates_, scores_, saliency_, model_.box, dets_, box_scratch_);
      model_.finish_map(work_gray_, saliency_, map_scratch_, map_options_);
      roi_runs_.fill_outside(saliency_, 0.f);
      if (dets_.size() > static_cast<std::size_t>(max_detections_))
        dets_.resize(static_cast<std::size_t>(max_detections_));
      rank_and_range();
      return;
    }
    if (peer_) {
      peer_->compute(work_gray_, saliency_);
    } else {
      const cv::Mat* heights = nullptr;  // SAMS: the DTM with its unsearched region filled
      if (method_ == Method::kSams && level == 2) {
        pad_quarter(height);
        cv::patchNaNs(work_height4_, 0.0);
        roi4_runs_.fill_outside(work_height4_, static_cast<float>(roi4_runs_.mean<float>(work_height4_)));
        heights = &work_height4_;
      } else if (method_ == Method::kSams) {
        height.copyTo(work_height_);
        cv::patchNaNs(work_height_, 0.0);
        roi_runs_.fill_outside(work_height_, static_cast<float>(roi_runs_.mean<float>(work_height_)));
        heights = &work_height_;
      }
      saliency_of(heights, level);
    }
    roi_runs_.fill_outside(saliency_, 0.f);
    detector_->detect(saliency_, dets_);
    rank_and_range();
  }

  /// saliency_ := Itti / SAMS of work_gray_ (and `heights`, nullptr = none; level 0 or 2), through
  /// the enlarged frame when the camera is smaller than the pyramid (into pre-sized buffers).
  void saliency_of(const cv::Mat* heights, int level) {
    static const cv::Mat kNone;
    if (input_size_ == size_) {
      itti_->compute(work_gray_, heights != nullptr ? *heights : kNone, saliency_);
      return;
    }
    work_gray_.convertTo(gray_f_, CV_32F, 1.0 / 255.0);
    up_gray_.apply(gray_f_, big_gray_);
    cv::Mat* big_heights = nullptr;
    if (heights != nullptr) {
      big_heights = level == 2 ? &big_height4_ : &big_height_;
      (level == 2 ? up_height4_ : up_gray_).apply(*heights, *big_heights);
    }
    itti_->compute(big_gray_, big_heights != nullptr ? *big_heights : kNone, big_saliency_);
    down_.apply(big_saliency_, saliency_);
  }

  /// dets_ (best first) -> last_: ranged rocks, hazards.
  void rank_and_range() {
    last_.count = 0;
    last_.hazards = 0;
    for (const Detection& det : dets_) {
      if (last_.count >= kMaxRocks) break;
      RangedRock& r = last_.rocks[last_.count++];
      r = range_rock(det, ranger_, ranging_);
      if (r.hazard) ++last_.hazards;
    }
    last_.image_width = size_.width;
    last_.image_height = size_.height;
  }

  void publish(TimeNs stamp, std::uint64_t sequence) {
    last_.stamp = stamp;
    last_.sequence = sequence;
    if (RockFrame* f = rocks_out_->begin_write()) {
      *f = last_;
      rocks_out_->commit();
    }
    if (RockProbabilityFrame* g = prob_out_->begin_write()) {
      const float* s = saliency_.ptr<float>(0);  // continuous (created by resize)
      const float nan = std::numeric_limits<float>::quiet_NaN();
      for (int i = 0; i < cell_pixel_.rows; ++i) {
        const int* idx = cell_pixel_.ptr<int>(i);
        float* out = g->probability.ptr<float>(i);
        for (int j = 0; j < cell_pixel_.cols; ++j) out[j] = idx[j] >= 0 ? s[idx[j]] : nan;
      }
      g->stamp = stamp;
      g->sequence = sequence;
      prob_out_->commit();
    }
    if (msg_) {
      if (RockArrayMsg* m = msg_->begin()) {
        fill_message(*m);
        msg_->commit();
      }
    }
  }

  void fill_message(RockArrayMsg& m) const {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    dds::set_stamp(m.header.stamp, last_.stamp);
    const std::size_t n = last_.count;
    dds::set_length(m.detections, n);
    dds::set_length(m.ground_range_m, n);
    dds::set_length(m.lateral_offset_m, n);
    dds::set_length(m.width_m, n);
    dds::set_length(m.height_m, n);
    dds::set_length(m.hazard, n);
    for (std::uint32_t i = 0; i < m.detections._length; ++i) {
      const RangedRock& r = last_.rocks[i];
      const cv::Rect& b = r.detection.box;
      auto& d = m.detections._buffer[i];
      dds::set_stamp(d.header.stamp, last_.stamp);
      auto& hyp = d.results._buffer[0];
      hyp.hypothesis.score = r.detection.score;
      // Pose of the hypothesis: ground position of the rock's base (body frame, m).
      hyp.pose.pose.position.x = r.ranged ? r.range_m : nan;
      hyp.pose.pose.position.y = r.ranged ? r.lateral_m : nan;
      hyp.pose.pose.position.z = 0.0;
      // Box centre / size in px (continuous coordinates: pixel k spans [k, k + 1)).
      d.bbox.center.position.x = b.x + 0.5 * b.width;
      d.bbox.center.position.y = b.y + 0.5 * b.height;
      d.bbox.center.theta = 0.0;
      d.bbox.size_x = b.width;
      d.bbox.size_y = b.height;
      m.ground_range_m._buffer[i] = r.ranged ? r.range_m : nan;
      m.lateral_offset_m._buffer[i] = r.ranged ? r.lateral_m : nan;
      m.width_m._buffer[i] = r.ranged ? r.width_m : nan;
      m.height_m._buffer[i] = r.ranged ? r.height_m : nan;
      m.hazard._buffer[i] = r.hazard;
    }
  }

  Method method_ = Method::kSams;
  std::string method_name_ = "sams";
  bool trained_ = false;
  int max_detections_ = 32;
  // method trained
  TrainedModel model_;  // its BoxParams as the parameters set them
  std::unique_ptr<CandidateExtractor> extractor_;
  CandidateSet candidates_;
  std::vector<float> scores_;
  std::vector<int> score_spans_;  // TrainedModel::score_map's scratch
  TrainedModel::BoxScratch box_scratch_;
  TrainedMapOptions map_options_;  // map_guide_radius_px, map_guide_eps, pixel_stage
  TrainedMapScratch map_scratch_;
  cv::Size size_;
  RangingParams ranging_;
  std::unique_ptr<direct_depth::DirectDepth> depth_;
  std::unique_ptr<runtime::WorkerPool> workers_;  // `threads` > 1; outlives itti_, which uses it
  std::unique_ptr<IttiSaliency> itti_;
  std::unique_ptr<OpenCvSaliency> peer_;
  std::unique_ptr<BoxDetector> detector_;
  GroundRanger ranger_;
  common::GridGeometry grid_;  ///< of the rock_probability layer
  double max_range_m_ = 10.0;
  cv::Mat roi_;                      // CV_8U 255 = searched, 0 = not searched
  cv::Mat work_gray_, work_height_;  // the DTM's images with the unsearched region filled
  cv::Mat work_height4_, roi4_;      // the quarter solve at pyramid level 2, its searched region
  RegionRuns roi_runs_, roi4_runs_;  // roi_ and roi4_ as runs along their rows
  bool quarter_ok_ = false;          // the structure pyramid can start at level 2 (centre_min >= 2)
  cv::Mat cell_pixel_;               // CV_32S, per grid cell the pixel index r * w + c or -1
  cv::Mat saliency_;
  // a camera smaller than the pyramid: its frames enlarged to input_size_ and the map brought back
  cv::Size input_size_;
  ResizeTable up_gray_, up_height4_, down_;  // up_gray_ also serves the full-resolution heights
  cv::Mat gray_f_, big_gray_, big_height_, big_height4_, big_saliency_;
  std::vector<Detection> dets_;
  RockFrame last_;
  const runtime::Input<common::DtmFrame>* dtm_ = nullptr;
  LatestPool<RockFrame>* rocks_out_ = nullptr;
  LatestPool<RockProbabilityFrame>* prob_out_ = nullptr;
  std::shared_ptr<dds::Outbox<RockArrayMsg>> msg_;
  runtime::InputWatch* input_ = nullptr;
  NewValue new_dtm_;
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "sams",
      "terrain/dtm -> SAMS / Itti / OpenCV saliency -> ranged rock boxes (terrain/rocks) + "
      "rock_probability grid layer (terrain/rock_probability)",
      [] { return std::make_unique<SamsComponent>(); });
}

}  // namespace regolith::saliency
