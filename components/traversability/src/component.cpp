// Component "traversability": shared DTM -> metric grid map (channel + grid_map_msgs/GridMap).
#include "regolith/traversability/component.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "regolith/common/camera.hpp"
#include "regolith/common/grid_params.hpp"
#include "regolith/common/payloads.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/runtime/application.hpp"

namespace regolith::traversability {
namespace {

using GridMapMsg = msgs::grid_map_msgs::GridMap;

class TraversabilityComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    // The camera whose DTM frames this maps (its calibration and mount: rover.cameras.<camera>).
    p.reject_moved("camera_model",
                   "the camera is described once, in rover.cameras.<camera> {camera_info, mount}; "
                   "write `camera: <device>` here");
    const RoverCamera& rc = ctx.rover_camera(p, "camera");
    const direct_depth::CameraModel model = common::camera_model_of(rc);
    const int w = model.width, h = model.height;

    TraversabilityParams tp;
    tp.set_grid(common::read_grid_geometry(p, tp.grid(), "grid map"));
    tp.detrend_sigma_px = p.get<double>("detrend_sigma_px", tp.detrend_sigma_px,
                                        {.unit = "px", .min = 0.0, .doc = "low-frequency SfS drift removed (0 = off)"});
    tp.height_gain =
        p.get<double>("height_gain", tp.height_gain,
                      {.min = 0.0, .min_exclusive = true, .doc = "extra multiplier on metric SfS heights"});
    tp.max_range_m =
        p.get<double>("max_range_m", tp.max_range_m,
                      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "pixels farther than this are ignored"});
    tp.critical_slope_rad = p.get<double>(
        "critical_slope_rad", tp.critical_slope_rad,
        {.unit = "rad", .min = 0.0, .max = 1.57, .min_exclusive = true, .doc = "slope with traversability_slope = 0"});
    tp.critical_step_m =
        p.get<double>("critical_step_m", tp.critical_step_m,
                      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "step with traversability_step = 0"});
    tp.critical_roughness_m = p.get<double>(
        "critical_roughness_m", tp.critical_roughness_m,
        {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "roughness with traversability_roughness = 0"});
    tp.slope_radius_m =
        p.get<double>("slope_radius_m", tp.slope_radius_m,
                      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "plane-fit neighbourhood"});
    tp.step_radius_m = p.get<double>("step_radius_m", tp.step_radius_m,
                                     {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "max-min neighbourhood"});
    tp.weight_slope = p.get<double>("weight_slope", tp.weight_slope, {.min = 0.0, .doc = "weight of the slope score"});
    tp.weight_step = p.get<double>("weight_step", tp.weight_step, {.min = 0.0, .doc = "weight of the step score"});
    tp.weight_roughness =
        p.get<double>("weight_roughness", tp.weight_roughness, {.min = 0.0, .doc = "weight of the roughness score"});
    tp.full_confidence_points =
        p.get<double>("full_confidence_points", tp.full_confidence_points,
                      {.min = 0.0, .min_exclusive = true, .doc = "pixels per cell for confidence 1"});
    // Where the map's SfS runs (README "Two SfS paths"): "ground" = this component resamples the
    // DTM frame's grey image onto the ground plane and solves it there with the sun in the ground
    // frame (metric by construction); "image" = the sfs component's image-frame heights, scaled.
    const std::string frame = p.get<std::string>(
        "sfs_frame", "ground",
        {.choices = {"ground", "image"}, .doc = "SfS on the ground-rectified image or in the image frame"});
    ground_ = frame == "ground";
    tp.rectify_resolution_m = p.get<double>("rectify_resolution_m", tp.rectify_resolution_m,
                                            {.unit = "m",
                                             .min = 0.0,
                                             .min_exclusive = true,
                                             .doc = "cell of the ground-rectified image (sfs_frame ground)"});
    tp.ground_detrend_sigma_m =
        p.get<double>("ground_detrend_sigma_m", tp.ground_detrend_sigma_m,
                      {.unit = "m", .min = 0.0, .doc = "ground SfS drift removed (0 = off; sfs_frame ground)"});
    const std::string gmethod =
        p.get<std::string>("ground_method", "tsai_shah",
                           {.choices = {"tsai_shah", "pentland"},
                            .doc = "ground SfS solver (tsai_shah: the more accurate on the rectified grid)"});
    tp.ground_sfs.method = sfs::method_from_string(gmethod);
    tp.ground_sfs.tsai_shah_leak_px =
        p.get<double>("ground_leak_px", tp.ground_sfs.tsai_shah_leak_px,
                      {.unit = "px", .min = 0.0, .doc = "Tsai-Shah integration memory on the rectified grid"});
    const std::string frame_id =
        p.get<std::string>("frame_id", "base_link", {.doc = "header.frame_id of the grid map"});
    const double timeout_s = p.get<double>(
        "input_timeout_s", 2.0,
        {.unit = "s", .min = 0.0, .min_exclusive = true, .doc = "the DTM input is stale after this long"});
    try {
      depth_ = std::make_unique<direct_depth::DirectDepth>(model);
      mapper_ = std::make_unique<TraversabilityMapper>(*depth_, tp);
    } catch (const std::invalid_argument& e) {
      p.fail({}, e.what());
    }
    // Warm-up on a flat DTM: sizes every buffer of the mapper and of map_.
    cv::Mat flat(h, w, CV_32F, cv::Scalar(0));
    mapper_->compute_from_sfs(flat, cv::Mat(), {0.5, 0.5}, map_);
    if (ground_) {  // and the ground solver's buffers (a shaded ramp so every branch runs)
      cv::Mat ramp(h, w, CV_8U);
      for (int r = 0; r < h; ++r)
        for (int c = 0; c < w; ++c) ramp.at<uchar>(r, c) = static_cast<uchar>(60 + (r * 7 + c * 3) % 120);
      mapper_->compute_from_image(ramp, {0.5, 0.5}, map_);
    }
    // Layers other components measure, appended after the mapper's own (NaN until they arrive).
    const std::vector<std::string> available{common::kRockProbabilityLayer, "sinkage"};
    const auto extra = p.get<std::vector<std::string>>(
        "extra_layers", {},
        {.choices = available,
         .doc = "layers merged from other components: rock_probability (sams), sinkage (soil_stiffness)"});
    full_ = map_;
    for (auto& m : full_.data) m = m.clone();
    base_layers_ = map_.data.size();
    for (const auto& name : extra) {
      full_.layers.push_back(name);
      full_.data.emplace_back(map_.size_x(), map_.size_y(), CV_32F,
                              cv::Scalar(std::numeric_limits<float>::quiet_NaN()));
      if (name == common::kRockProbabilityLayer) {
        rock_index_ = full_.data.size() - 1;
        rocks_ = &ctx.consume<common::RockProbabilityFrame>(common::kRockProbabilityChannel);
      }
      if (name == "sinkage") {
        sinkage_index_ = full_.data.size() - 1;
        sinkage_ = &ctx.consume<common::SinkageLayer>(common::kSinkageLayerChannel);
      }
    }
    const GridMap proto = full_;
    dtm_ = &ctx.consume<common::DtmFrame>(common::kDtmChannel);
    if (!ground_) ctx.want(common::kDtmChannel, common::kDtmHeight);  // the image path maps the sfs heights
    out_ = &ctx.produce<GridMapFrame>(kGridMapChannel, 4, [proto] {
      GridMapFrame f;
      f.map = proto;
      for (auto& m : f.map.data) m = m.clone();
      return f;
    });
    input_ = &watch_input("dtm", from_seconds(timeout_s));
    if (dds::Participant* part = ctx.dds()) {
      const dds::TopicInfo* info = dds::find_topic(kGridMapChannel);
      if (info == nullptr) p.fail({}, "DDS topic terrain/grid_map is unknown to this build");
      const auto nx = static_cast<std::uint32_t>(map_.size_x()), ny = static_cast<std::uint32_t>(map_.size_y());
      const GridMap& g = full_;
      msg_ = part->make_outbox<GridMapMsg>(
          kGridMapChannel, info->writer_qos(), dds::OutboxOptions{dds::OutboxMode::kLatest, 4},
          [nx, ny, &g, &frame_id](GridMapMsg& m) {
            const auto nl = static_cast<std::uint32_t>(g.layers.size());
            dds::reserve(m, dds::GridMapCapacity{nl, 1, nx, ny, 32, 32});
            dds::copy_string(m.header.frame_id, 32, frame_id);
            dds::set_length(m.layers, nl);
            dds::set_length(m.data, nl);  // reserve() sizes every layer; the sequence length is ours
            for (std::uint32_t k = 0; k < nl; ++k) dds::copy_string(m.layers._buffer[k], 32, g.layers[k]);
            dds::set_length(m.basic_layers, 1);
            dds::copy_string(m.basic_layers._buffer[0], 32, "elevation");
            m.info.resolution = g.resolution_m;
            m.info.length_x = g.length_x_m;
            m.info.length_y = g.length_y_m;
            m.info.pose.position.x = g.center_x_m;
            m.info.pose.position.y = g.center_y_m;
          });
    }
  }

  void step(const runtime::CycleInfo& c) override {
    auto lease = dtm_->acquire();
    if (!lease) return;
    const common::DtmFrame& d = *lease;
    if (!new_dtm_(lease.generation())) return;
    input_updated(*input_, c.now);
    const cv::Size sz(depth_->model().width, depth_->model().height);
    if (d.height.size() != sz || d.gray.size() != sz || (!d.valid.empty() && d.valid.size() != sz)) {
      count_error();
      set_status("DTM size differs from the camera calibration (rover.cameras)");
      return;
    }
    if (d.gray.type() != CV_8UC1 || d.height.type() != CV_32FC1 || (!d.valid.empty() && d.valid.type() != CV_8UC1)) {
      count_error();
      set_status("DTM frame of the wrong type");
      return;
    }
    // Inputs checked: the mapper neither throws nor allocates here.
    if (ground_)
      mapper_->compute_from_image(d.gray, d.light, map_);
    else
      mapper_->compute_from_sfs(d.height, d.valid, d.light, map_);
    for (std::size_t k = 0; k < base_layers_; ++k) map_.data[k].copyTo(full_.data[k]);
    merge_extra_layers(d.sequence);
    if (GridMapFrame* f = out_->begin_write()) {
      for (std::size_t k = 0; k < full_.data.size(); ++k) full_.data[k].copyTo(f->map.data[k]);
      f->stamp = d.stamp;
      f->sequence = d.sequence;
      out_->commit();
    }
    if (msg_) {
      if (GridMapMsg* m = msg_->begin()) {
        dds::set_stamp(m->header.stamp, d.stamp);
        for (std::size_t k = 0; k < full_.data.size(); ++k) {
          auto& seq = m->data._buffer[k].data;
          export_column_major(full_, k, seq._buffer, seq._length);
        }
        msg_->commit();
      }
    }
    set_status("ok");
  }

  std::string result() const override {
    const auto l = out_ != nullptr ? out_->acquire() : decltype(out_->acquire()){};
    if (!l || l->map.data.empty()) return {};
    const cv::Mat& t = l->map.layer("traversability");
    int unknown = 0, hazard = 0;
    for (int r = 0; r < t.rows; ++r)
      for (int c = 0; c < t.cols; ++c) {
        const float v = t.at<float>(r, c);
        if (!(v == v))
          ++unknown;
        else if (v <= 0.0f)
          ++hazard;
      }
    char buf[96];
    std::snprintf(buf, sizeof buf, "map %.0f %% unknown, %d hazard cells (traversability 0)",
                  100.0 * unknown / static_cast<double>(t.total()), hazard);
    return buf;
  }

 private:
  // Copies the newest layers of other components into full_ (NaN when absent or mismatched).
  void merge_extra_layers(std::uint64_t sequence) {
    constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();
    if (rocks_ != nullptr) {
      cv::Mat& dst = full_.data[rock_index_];
      auto r = rocks_->acquire();
      // Same frame and same grid only: the sams component runs before this one in the group.
      if (r && r->sequence == sequence && r->probability.size() == dst.size() && r->same_as(map_)) {
        r->probability.copyTo(dst);
      } else {
        fill_nan(dst, kNaN);
      }
    }
    if (sinkage_ != nullptr) {
      cv::Mat& dst = full_.data[sinkage_index_];
      auto l = sinkage_->acquire();
      if (l && l->valid) {
        common::rasterise_sinkage(*l, map_, dst);
      } else {
        fill_nan(dst, kNaN);
      }
    }
  }
  static void fill_nan(cv::Mat& m, float nan) {
    for (int r = 0; r < m.rows; ++r) {
      float* row = m.ptr<float>(r);
      for (int c = 0; c < m.cols; ++c) row[c] = nan;
    }
  }

  GridMap full_;  // the mapper's layers + extra layers, as published
  std::size_t base_layers_ = 0;
  const runtime::Input<common::RockProbabilityFrame>* rocks_ = nullptr;
  std::size_t rock_index_ = 0;
  const runtime::Input<common::SinkageLayer>* sinkage_ = nullptr;
  std::size_t sinkage_index_ = 0;
  std::unique_ptr<direct_depth::DirectDepth> depth_;
  std::unique_ptr<TraversabilityMapper> mapper_;
  bool ground_ = true;
  GridMap map_;
  const runtime::Input<common::DtmFrame>* dtm_ = nullptr;
  LatestPool<GridMapFrame>* out_ = nullptr;
  std::shared_ptr<dds::Outbox<GridMapMsg>> msg_;
  runtime::InputWatch* input_ = nullptr;
  NewValue new_dtm_;
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "traversability", "terrain/dtm + camera model -> metric elevation and traversability layers (terrain/grid_map)",
      [] { return std::make_unique<TraversabilityComponent>(); });
}

}  // namespace regolith::traversability
