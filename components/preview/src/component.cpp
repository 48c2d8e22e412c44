// camera_preview: copies the source frame and its result into a free slot in step() (no
// allocation: slots are sized at configure time), hands the slot to the component's worker thread,
// which scales, draws, encodes the JPEG and publishes it (channel + DDS outbox).
#include "regolith/preview/component.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <memory>
#include <string>
#include <thread>

#include "regolith/common/camera.hpp"
#include "regolith/common/payloads.hpp"
#include "regolith/dds/outbox.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/preview/preview.hpp"
#include "regolith/runtime/component.hpp"
#include "regolith/runtime/context.hpp"
#include "regolith/saliency/component.hpp"
#include "regolith/sinkage/component.hpp"
#include "regolith/traversability/component.hpp"

namespace regolith::preview {
namespace {

using CompressedImageMsg = msgs::sensor_msgs::CompressedImage;

enum class Source : std::uint8_t { kRocks, kSinkage };

/// A frame and what was found in it, handed from step() to the worker.
struct Slot {
  cv::Mat frame;  ///< the camera's size and type, allocated at configure
  saliency::RockFrame rocks;
  /// The traversability grid of the rocks' frame (hazard_map), leased in step() while it was the
  /// newest, released by the worker once drawn: the overlay does not depend on the worker's timing.
  LatestPool<traversability::GridMapFrame>::Lease grid;
  sinkage::WheelSinkageSample sinkage;
  TimeNs stamp = 0;
  std::uint64_t sequence = 0;
};

class PreviewComponent final : public runtime::Component {
 public:
  ~PreviewComponent() override { stop_worker(); }

  void configure(Params& p, runtime::Context& ctx) override {
    const std::string source = p.get<std::string>(
        "source", "rocks",
        {.choices = {"rocks", "sinkage"},
         .doc = "rocks: front camera + rock boxes (terrain/dtm + terrain/rocks); sinkage: hub camera + "
                "wheel_sinkage result (camera device + terrain/wheel_sinkage)"});
    source_ = source == "sinkage" ? Source::kSinkage : Source::kRocks;
    hal::Camera& cam = ctx.camera(p, "camera");  // rocks: the camera the DTM comes from (its size, frame id)
    const hal::CameraFormat fmt = cam.format();
    width_ = p.get<int>("width", 320,
                        {.unit = "px",
                         .min = 16,
                         .max = 4096,
                         .doc = "preview width (height keeps the aspect ratio; never wider than the camera)"});
    quality_ = p.get<int>("jpeg_quality", 80, {.min = 1, .max = 100, .doc = "JPEG quality"});
    const double rate = p.get<double>("max_rate_hz", 2.0,
                                      {.unit = "Hz",
                                       .min = 0.0,
                                       .min_exclusive = true,
                                       .doc = "at most this many previews per second (of the run's clock)"});
    min_interval_ = static_cast<TimeNs>(1e9 / rate);
    const RoverCamera* described = ctx.rover().camera(cam.id());
    frame_id_ = p.get<std::string>(
        "frame_id", described != nullptr ? described->frame_id : cam.id() + "_optical_frame",
        {.doc = "header.frame_id (default: rover.cameras.<camera>.frame_id, else <camera>_optical_frame)"});

    size_ = {fmt.width, fmt.height};
    const int type = source_ == Source::kSinkage ? CV_8UC3 : CV_8UC1;  // wheel_sinkage needs bgr8; the DTM is grey
    for (auto& s : slots_) s.frame.create(size_, type);
    free_ = std::make_unique<BoundedQueue<int>>(kSlots, DropPolicy::kDropNewest);
    ready_ = std::make_unique<BoundedQueue<int>>(kSlots, DropPolicy::kDropNewest);
    for (int i = 0; i < kSlots; ++i) free_->push(i);

    const cv::Size out = preview_size(size_, width_);
    capacity_ = static_cast<std::uint32_t>(out.area()) * 3u + 4096u;  // a JPEG never needs more in practice
    const bool hazard = p.get<bool>("hazard_map", false,
                                    {.doc = "source rocks: tint what the camera sees of the traversability grid "
                                            "(channel terrain/grid_map) red by 1 - traversability"});
    if (source_ == Source::kRocks) {
      dtm_ = &ctx.consume<common::DtmFrame>(common::kDtmChannel);
      rocks_ = &ctx.consume<saliency::RockFrame>(saliency::kRocksChannel);
      if (hazard) {
        grid_ = &ctx.consume<traversability::GridMapFrame>(traversability::kGridMapChannel);
        try {
          depth_ = std::make_unique<direct_depth::DirectDepth>(common::camera_model_of(ctx.rover_camera(p, "camera")));
        } catch (const std::invalid_argument& e) {
          p.fail("camera", e.what());
        }
        if (depth_->range_map().size() != size_)
          p.fail("camera", "rover.cameras." + cam.id() + " describes a " + std::to_string(depth_->range_map().cols) +
                               "x" + std::to_string(depth_->range_map().rows) + " image but the device delivers " +
                               std::to_string(size_.width) + "x" + std::to_string(size_.height));
      }
    } else {
      if (hazard) p.fail("hazard_map", "only for source: rocks (the front camera and the traversability grid)");
      cam_ = &cam;
      sinkage_ = &ctx.consume<sinkage::WheelSinkageSample>(sinkage::kSinkageChannel);
    }
    topic_ = source_ == Source::kRocks ? "preview/rocks/compressed" : "preview/sinkage/compressed";
    const std::uint32_t cap = capacity_;
    out_ = &ctx.produce<PreviewImage>(source_ == Source::kRocks ? "preview/rocks" : "preview/sinkage", 4, [cap] {
      PreviewImage im;
      im.jpeg.reserve(cap);
      return im;
    });
    if (dds::Participant* part = ctx.dds()) {
      const dds::TopicInfo* info = dds::find_topic(topic_);
      if (info == nullptr) p.fail({}, "DDS topic " + topic_ + " is unknown to this build");
      const std::string frame = frame_id_;
      msg_ = part->make_outbox<CompressedImageMsg>(topic_, info->writer_qos(),
                                                   dds::OutboxOptions{dds::OutboxMode::kLatest, 2},
                                                   [cap, frame](CompressedImageMsg& m) {
                                                     dds::reserve(m, cap, 16, 64);
                                                     dds::copy_string(m.header.frame_id, 64, frame);
                                                     dds::copy_string(m.format, 16, "jpeg");
                                                   });
    }
  }

  void activate() override {
    next_due_ = 0;
    new_input_.reset();
    stop_.store(false);
    worker_ = std::thread([this] { worker_loop(); });
  }
  void deactivate() override { stop_worker(); }

  void step(const runtime::CycleInfo& c) override {
    if (c.now < next_due_) return;
    if (source_ == Source::kRocks ? take_rocks() : take_sinkage()) next_due_ = c.now + min_interval_;
  }

  void diagnostics(std::vector<std::pair<std::string, std::string>>& kv) const override {
    kv.emplace_back("topic", topic_);
    kv.emplace_back("previews", std::to_string(published_.load()));
    kv.emplace_back("skipped_busy", std::to_string(busy_.load()));
    kv.emplace_back("unmatched_frames", std::to_string(unmatched_.load()));
    kv.emplace_back("encode_failures", std::to_string(encode_failures_.load()));
    kv.emplace_back("last_jpeg_bytes", std::to_string(last_bytes_.load()));
    if (grid_ != nullptr) kv.emplace_back("hazard_overlays", std::to_string(hazard_overlays_.load()));
  }

  std::string result() const override {
    const std::uint64_t n = published_.load();
    if (n == 0) return {};
    return std::to_string(n) + " previews, last " + std::to_string(last_bytes_.load() / 1024) + " KiB";
  }

 private:
  static constexpr int kSlots = 3;

  // ---- step side (real time): copy into a free slot, no allocation ----
  /// Copies `image` (the slots' size and type: no reallocation) and, through fill(slot), the
  /// result into a free slot and hands it to the worker; false when the worker holds every slot.
  template <class Fill>
  bool hand_over(const cv::Mat& image, TimeNs stamp, std::uint64_t sequence, Fill&& fill) {
    int idx = 0;
    if (!free_->pop(idx)) {
      busy_.fetch_add(1, std::memory_order_relaxed);  // the worker is behind: skip this one
      return false;
    }
    Slot& s = slots_[static_cast<std::size_t>(idx)];
    image.copyTo(s.frame);
    fill(s);
    s.stamp = stamp;
    s.sequence = sequence;
    ready_->push(idx);
    return true;
  }

  bool take_rocks() {
    auto rocks = rocks_->acquire();
    if (!rocks || !new_input_(rocks.generation())) return false;
    auto dtm = dtm_->acquire();
    // The DTM of the rocks' frame: sfs and sams run in one rate group, so the newest DTM is it
    // unless sfs has already moved on (then this frame gets no preview).
    if (!dtm || dtm->sequence != rocks->sequence || dtm->gray.size() != size_ || dtm->gray.type() != CV_8UC1 ||
        rocks->image_width != size_.width || rocks->image_height != size_.height) {
      unmatched_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    return hand_over(dtm->gray, rocks->stamp, rocks->sequence, [&](Slot& s) {
      s.rocks = *rocks;
      // The grid of the same frame (traversability runs before this in the rocks' rate group), held
      // by the slot until drawn: leased only once a slot is free, so at most kSlots leases, within
      // the channel's readers (GridMapFrame's 4).
      if (grid_ != nullptr)
        if (auto grid = grid_->acquire(); grid && grid->sequence == rocks->sequence) s.grid = std::move(grid);
    });
  }

  bool take_sinkage() {
    auto sample = sinkage_->acquire();
    if (!sample || !new_input_(sample.generation())) return false;
    hal::FrameLease frame;
    // The frame the result was computed on: the newest at its capture time (mock cameras serve
    // frames by time, so that is exactly it; a hardware camera serves its newest frame, which is it
    // unless a newer one has arrived since: then the sequence numbers differ and nothing is drawn).
    if (!cam_->latest(sample->stamp, frame) || frame->sequence != sample->sequence || frame->corrupt ||
        frame->image.size() != size_ || frame->image.type() != CV_8UC3) {
      unmatched_.fetch_add(1, std::memory_order_relaxed);
      return false;
    }
    return hand_over(frame->image, sample->stamp, sample->sequence, [&](Slot& s) { s.sinkage = *sample; });
  }

  // ---- worker thread (not real time): draw, encode, publish ----
  void worker_loop() {
    cv::Mat scaled, out, cells;         // cells: the hazard overlay's pixel -> grid cell lookup
    common::GridGeometry cells_grid{};  // the grid `cells` was made for
    std::vector<std::uint8_t> jpeg;
    jpeg.reserve(capacity_);
    for (;;) {
      int idx = 0;
      if (!ready_->pop(idx)) {
        if (stop_.load()) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
        continue;
      }
      Slot& s = slots_[static_cast<std::size_t>(idx)];
      bool ok = false;
      try {
        if (source_ == Source::kRocks) {
          const std::span rocks(s.rocks.rocks.data(), std::min<std::size_t>(s.rocks.count, saliency::kMaxRocks));
          // the traversability grid of the same frame, leased by step()
          const traversability::GridMap* map = s.grid ? &s.grid->map : nullptr;
          if (map != nullptr && !map->layers.empty()) {
            const cv::Size size = preview_size(size_, width_);
            if (cells.size() != size || !cells_grid.same_as(*map)) {
              cells = grid_cell_lookup(*depth_, *map, size);
              cells_grid = *map;
            }
            const cv::Mat& t = map->layer("traversability");
            draw_rocks(s.frame, rocks, width_, out, HazardOverlay{&cells, &t});
            hazard_overlays_.fetch_add(1, std::memory_order_relaxed);
          } else {
            draw_rocks(s.frame, rocks, width_, out);
          }
        } else {
          draw_sinkage(s.frame, s.sinkage.geometry, s.sinkage.result, width_, scaled, out);
        }
        ok = encode_jpeg(out, quality_, jpeg) && jpeg.size() <= capacity_;
      } catch (const std::exception&) {
        ok = false;  // counted below; a bad frame must not stop the previews
      }
      const TimeNs stamp = s.stamp;
      const std::uint64_t sequence = s.sequence;
      s.grid.reset();  // the traversability component may write that slot again
      free_->push(idx);
      if (!ok) {
        encode_failures_.fetch_add(1, std::memory_order_relaxed);
        count_error();
        continue;
      }
      if (PreviewImage* im = out_->begin_write()) {
        im->stamp = stamp;
        im->sequence = sequence;
        im->width = out.cols;
        im->height = out.rows;
        im->jpeg.assign(jpeg.begin(), jpeg.end());  // within the reserved capacity
        out_->commit();
      }
      if (msg_) {
        if (CompressedImageMsg* m = msg_->begin()) {
          dds::set_stamp(m->header.stamp, stamp);
          dds::set_length(m->data, jpeg.size());
          std::copy(jpeg.begin(), jpeg.end(), m->data._buffer);
          msg_->commit();
        }
      }
      last_bytes_.store(jpeg.size(), std::memory_order_relaxed);
      published_.fetch_add(1, std::memory_order_relaxed);
    }
  }

  void stop_worker() {
    if (worker_.joinable()) {
      stop_.store(true);
      worker_.join();
    }
  }

  Source source_ = Source::kRocks;
  cv::Size size_;
  int width_ = 320, quality_ = 80;
  TimeNs min_interval_ = 0, next_due_ = 0;
  std::uint32_t capacity_ = 0;
  std::string frame_id_, topic_;
  std::array<Slot, kSlots> slots_;
  std::unique_ptr<BoundedQueue<int>> free_, ready_;
  const runtime::Input<common::DtmFrame>* dtm_ = nullptr;
  const runtime::Input<saliency::RockFrame>* rocks_ = nullptr;
  const runtime::Input<sinkage::WheelSinkageSample>* sinkage_ = nullptr;
  const runtime::Input<traversability::GridMapFrame>* grid_ = nullptr;
  std::unique_ptr<direct_depth::DirectDepth> depth_;  // the front camera, for the hazard overlay
  hal::Camera* cam_ = nullptr;
  NewValue new_input_;
  LatestPool<PreviewImage>* out_ = nullptr;
  std::shared_ptr<dds::Outbox<CompressedImageMsg>> msg_;
  std::thread worker_;
  std::atomic<bool> stop_{false};
  std::atomic<std::uint64_t> published_{0}, busy_{0}, unmatched_{0}, encode_failures_{0}, last_bytes_{0},
      hazard_overlays_{0};
};

}  // namespace

void register_component() {
  runtime::ComponentRegistry::instance().add(
      "camera_preview",
      "camera frame + what the rover found in it (rock boxes or the wheel-sinkage overlay) -> JPEG "
      "preview/<source>/compressed (sensor_msgs/CompressedImage), drawn and encoded off the real-time threads",
      [] { return std::make_unique<PreviewComponent>(); });
}

}  // namespace regolith::preview
