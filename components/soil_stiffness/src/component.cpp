// Component "soil_stiffness": rear-camera frames -> SoilStiffnessEstimator -> channels
// "terrain/soil" + "terrain/sinkage_layer" and DDS topic terrain/soil. Every buffer (estimator
// workspace, estimate, channel slots, DDS samples) is allocated in configure(); step() does not
// allocate once the estimator is warm (see README "Real time" for the measurement).
#include "regolith/soil_stiffness/component.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <stdexcept>

#include "regolith/core/frame_order.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/context.hpp"
#include "regolith/soil_stiffness/config.hpp"

namespace regolith::soil {
namespace {

using SoilMsg = msgs::regolith_msgs::SoilStiffness;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr std::size_t kFrameIdCapacity = 32;

class SoilStiffnessComponent final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    camera_ = &ctx.camera(p, "camera");
    const hal::CameraFormat fmt = camera_->format();
    const RoverCamera& rover_camera = ctx.rover_camera(p, "camera");
    cfg_ = read_soil_config(p, ctx.rover(), rover_camera, fmt.width, fmt.height);
    const double stale_s =
        p.get<double>("stale_timeout_s", 10.0,
                      {.unit = "s",
                       .min = 0.0,
                       .min_exclusive = true,
                       .doc = "the rear camera is reported stale after this long without a new frame"});
    frame_id_ = p.get<std::string>("frame_id", rover_camera.name + "_ground",
                                   {.doc = "header.frame_id of terrain/soil (the camera ground frame of the profiles, "
                                           "<camera>_ground on /tf_static)"});
    if (frame_id_.size() > kFrameIdCapacity) p.fail("frame_id", "longer than 32 characters");
    try {
      estimator_ = std::make_unique<SoilStiffnessEstimator>(cfg_.camera, cfg_.rover, cfg_.analysis);
    } catch (const std::invalid_argument& e) {
      p.fail({}, e.what());
    }
    estimator_->reserve(estimate_);
    out_ = &ctx.produce<SoilStiffnessSample>(kSoilChannel);
    layer_ = &ctx.produce<SinkageLayer>(kSinkageLayerChannel, 2, [] { return SinkageLayer{}; });
    input_ = &watch_input("camera", static_cast<TimeNs>(stale_s * 1e9));
    order_ = FrameOrder(static_cast<TimeNs>(stale_s * 1e9));
    if (dds::Participant* dp = ctx.dds()) {
      const dds::TopicInfo* info = dds::find_topic(kSoilChannel);
      if (info == nullptr) p.fail({}, "DDS topic terrain/soil is not registered");
      const std::string frame = frame_id_;
      dds_ = dp->make_outbox<SoilMsg>(kSoilChannel, info->writer_qos(), dds::OutboxOptions{dds::OutboxMode::kLatest, 4},
                                      [frame](SoilMsg& m) {
                                        dds::reserve(m, dds::SoilStiffnessCapacity{32, kFrameIdCapacity});
                                        dds::copy_string(m.header.frame_id, kFrameIdCapacity, frame);
                                      });
    }
  }

  void step(const runtime::CycleInfo& c) override {
    hal::FrameLease lease;
    if (!camera_->latest(c.now, lease)) return;
    const hal::Frame& f = *lease;
    if (!new_frame_(f.sequence)) return;
    // The estimate and the sinkage layer (placed at the odometry of its stamp) never go back in time.
    if (order_.admit(f.capture_time) == FrameOrder::Verdict::kOutOfOrder) {
      set_status("rear frame stamped at or before the last one (the camera clock stepped back): skipped");
      return;
    }
    input_updated(*input_, c.now);
    if (f.corrupt) {
      count_error();
      set_status("corrupt rear frame skipped");
      return;
    }
    if (f.image.empty() || f.image.cols != cfg_.camera.width || f.image.rows != cfg_.camera.height ||
        (f.image.type() != CV_8UC1 && f.image.type() != CV_8UC3)) {
      // a camera that renegotiated its format: counted, never an exception in the cycle
      count_error();
      set_status("rear frame rejected (size or pixel format differs from the camera calibration)");
      return;
    }
    estimator_->estimate(f.image, cfg_.sun, estimate_);
    processed_.fetch_add(1, std::memory_order_relaxed);
    if (estimate_.ok) {
      estimates_.fetch_add(1, std::memory_order_relaxed);
      set_status("ok");
    } else {
      set_status("no estimate for the last rear frame (reason on channel terrain/soil)");
    }
    publish(f);
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("frames_processed", std::to_string(processed_.load()));
    kv.emplace_back("estimates", std::to_string(estimates_.load()));
    kv.emplace_back("frames_out_of_order", std::to_string(order_.out_of_order()));
    kv.emplace_back("clock_steps", std::to_string(order_.clock_steps()));
  }

  std::string result() const override {
    const auto l = out_ != nullptr ? out_->acquire() : decltype(out_->acquire()){};
    if (!l) return {};
    if (!l->ok) return std::string("no estimate: ") + l->reason;
    const double k = l->k, n = l->n, ks = l->k_sigma;
    char buf[128];
    std::snprintf(buf, sizeof buf, "k %.3g n %.2f%s (+-%.0f %%), sinkage %.1f mm, %u tracks", k, n,
                  l->joint ? "" : " fixed", 100.0 * ks / k, l->mean_sinkage_m * 1e3, l->tracks);
    return buf;
  }

 private:
  void publish(const hal::Frame& f) {
    const SoilEstimate& e = estimate_;
    if (SoilStiffnessSample* s = out_->begin_write()) {
      s->stamp = f.capture_time;
      s->sequence = f.sequence;
      s->ok = e.ok;
      const std::size_t n = std::min(e.reason.size(), sizeof s->reason - 1);
      std::memcpy(s->reason, e.reason.data(), n);
      s->reason[n] = '\0';
      s->joint = e.ok && e.n_data_std > 0.0;
      // the reported pair: the joint fit's n with the prior on n (SoilEstimate::k, n)
      s->k = !e.ok ? kNaN : e.k;
      s->n = !e.ok ? kNaN : e.n;
      s->k_sigma = !e.ok ? kNaN : e.k_std;
      s->n_sigma = !e.ok ? kNaN : e.n_std;
      s->k_fixed = e.ok ? e.k_fixed : kNaN;
      s->k_fixed_sigma = e.ok ? e.k_fixed_std : kNaN;
      s->n_fixed = e.n_fixed;
      s->mean_sinkage_m = e.ok ? e.mean_sinkage_m : kNaN;
      s->samples_used = e.ok ? static_cast<std::uint32_t>(e.samples_used) : 0u;
      s->tracks = e.ok ? static_cast<std::uint32_t>(e.tracks.size()) : 0u;
      s->soil_class = e.ok ? e.soil_class : SoilClass::kUnknown;
      s->class_pressure_pa = e.ok ? e.class_pressure_pa : kNaN;
      out_->commit();
      if (dds_) {
        if (SoilMsg* m = dds_->begin()) {
          dds::set_stamp(m->header.stamp, s->stamp);
          m->k = s->k;
          m->n = s->n;
          m->k_sigma = s->k_sigma;
          m->n_sigma = s->n_sigma;
          m->mean_sinkage_m = s->mean_sinkage_m;
          m->samples_used = s->samples_used;
          dds::copy_string(m->soil_class, 32, e.ok ? to_string(e.soil_class) : "no_estimate");
          dds_->commit();
        }
      }
    }
    if (SinkageLayer* l = layer_->begin_write()) {
      fill_sinkage_layer(e, cfg_.rover.wheel_width_m, cfg_.mount, f.capture_time, f.sequence, *l);
      layer_->commit();
    }
  }

  hal::Camera* camera_ = nullptr;
  SoilConfig cfg_;
  std::string frame_id_;
  std::unique_ptr<SoilStiffnessEstimator> estimator_;
  SoilEstimate estimate_;
  LatestPool<SoilStiffnessSample>* out_ = nullptr;
  LatestPool<SinkageLayer>* layer_ = nullptr;
  runtime::InputWatch* input_ = nullptr;
  std::shared_ptr<dds::Outbox<SoilMsg>> dds_;
  NewValue new_frame_;
  FrameOrder order_;                         // the stale timeout as its step-back limit
  std::atomic<std::uint64_t> processed_{0};  // read by diagnostics() on the health thread
  std::atomic<std::uint64_t> estimates_{0};
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "soil_stiffness",
      "rear-camera wheel tracks -> sinkage profiles, Bernstein-Goriatchkin k (and n) -> terrain/soil, "
      "terrain/sinkage_layer",
      [] { return std::make_unique<SoilStiffnessComponent>(); });
}

}  // namespace regolith::soil
