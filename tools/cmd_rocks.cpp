// `regolith rocks` (detect rocks in images -> CSV, overlays, saliency maps) and
// `regolith eval rocks` (N-MODA / N-MODP / precision / recall / centroid hits /
// max F / MAE of every method on an image + mask folder; weight sweep and
// k-fold cross-validation). Algorithms: components/saliency. The SAMS structure
// channel needs regolith::sfs; when this file is compiled without it (header
// not on the include path), --method sams fails with a message.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "cli.hpp"
#include "regolith/core/csv.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/image_limits.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/saliency/contrast.hpp"
#include "regolith/saliency/dataset.hpp"
#include "regolith/saliency/detect.hpp"
#include "regolith/saliency/itti.hpp"
#include "regolith/saliency/model_file.hpp"
#include "regolith/saliency/peers.hpp"
#include "regolith/saliency/train_rocks.hpp"
#include "regolith/saliency/trained.hpp"

#ifdef REGOLITH_HAVE_SFS
#include "regolith/saliency/sfs_height.hpp"
#endif

namespace regolith::cli {

void add_rocks_commands(CLI::App& app);

namespace {

namespace fs = std::filesystem;
namespace sal = regolith::saliency;

// A model's box parameters as "<score threshold>, <NMS IoU>, <box refinement>, <crowd rule>",
// the crowd rule "off" or "<count>: <threshold>" (the training message, the CV's fold table).
std::string box_text(const sal::BoxParams& b) {
  char buf[96];
  if (b.crowd.on())
    std::snprintf(buf, sizeof buf, "%.2f, %.2f, %.2f, %d: %.2f", b.score_threshold, b.nms_iou, b.refine_fraction,
                  b.crowd.count, b.crowd.threshold);
  else
    std::snprintf(buf, sizeof buf, "%.2f, %.2f, %.2f, off", b.score_threshold, b.nms_iou, b.refine_fraction);
  return buf;
}
constexpr const char* kBoxTextFields = "score threshold, NMS IoU, box refinement, crowd rule (boxes: threshold)";

// Default SAMS weights, contrast parameters and post-processing (see
// components/saliency/README.md for the cross-validation that chose them).
// Method names of `regolith rocks`: every saliency method plus the trained ranking stage.
std::vector<std::string> rock_method_names() {
  std::vector<std::string> n = sal::method_names();
  n.push_back("trained");
  return n;
}

struct RockOptions {
  std::string method = "sams";
  std::string model;  // --method trained: model file (empty: the shipped one)
  double w_intensity = 0.2, w_orientation = 0.5, w_colour = 0.0, w_structure = 0.3;
  bool colour = false;
  // Unset: the method's default (sal::PostProcessParams, or
  // sal::contrast_post_processing() for contrast).
  std::optional<double> threshold_scale;
  std::optional<int> min_area;
  int open_radius = 2, close_radius = 2, max_detections = 0;
  double contrast_sigma = sal::ContrastParams{}.sigma_px;
  double contrast_smooth = sal::ContrastParams{}.smooth_sigma_px;
  int sfs_downsample = 2;
  double sfs_slant_deg = 45.0;
  std::string structure = "height";
  std::string normalisation = "local_max";

  void add_to(CLI::App* c) {
    c->add_option("--method", method, "sams|itti|contrast|spectral_residual|fine_grained|trained")
        ->check(CLI::IsMember(rock_method_names()))
        ->capture_default_str();
    c->add_option("--model", model,
                  "--method trained: model file from `regolith train rocks` "
                  "(default: the shipped " +
                      sal::default_trained_model_path() + ")");
    c->add_option("--w-intensity", w_intensity, "SAMS weight of the intensity channel")->capture_default_str();
    c->add_option("--w-orientation", w_orientation, "SAMS weight of the orientation channel")->capture_default_str();
    c->add_option("--w-colour", w_colour, "SAMS weight of the colour channel (needs --colour)")->capture_default_str();
    c->add_option("--w-structure", w_structure, "SAMS weight of the structure (SfS) channel")->capture_default_str();
    c->add_flag("--colour", colour, "use the RG/BY colour-opponency channel (Itti and SAMS)");
    const sal::PostProcessParams shared, contrast_pp = sal::contrast_post_processing();
    char buf[160];
    std::snprintf(buf, sizeof buf, "binary threshold = scale x Otsu (default %g; contrast: %g)", shared.threshold_scale,
                  contrast_pp.threshold_scale);
    c->add_option("--threshold-scale", threshold_scale, buf);
    std::snprintf(buf, sizeof buf, "px, smallest detected component kept (default %d; contrast: %d)", shared.min_area,
                  contrast_pp.min_area);
    c->add_option("--min-area", min_area, buf);
    c->add_option("--contrast-sigma", contrast_sigma, "px, contrast: sigma of the Gaussian surround in |I - G*I|")
        ->capture_default_str();
    c->add_option("--contrast-smooth", contrast_smooth, "px, contrast: sigma of the smoothing of |I - G*I| (0 = none)")
        ->capture_default_str();
    c->add_option("--open-radius", open_radius, "px, morphological opening radius")->capture_default_str();
    c->add_option("--close-radius", close_radius, "px, morphological closing radius")->capture_default_str();
    c->add_option("--max-detections", max_detections, "keep the best N boxes per image (0 = all)")
        ->capture_default_str();
    c->add_option("--sfs-downsample", sfs_downsample, "SfS runs at 1/2^N of the input size")->capture_default_str();
    c->add_option("--sfs-slant-deg", sfs_slant_deg, "deg, fixed light slant for the SfS (<0: estimate)")
        ->capture_default_str();
    c->add_option("--structure", structure, "SAMS structure feature: height|slope")
        ->check(CLI::IsMember({"height", "slope"}))
        ->capture_default_str();
    c->add_option("--normalisation", normalisation, "N(.): iterative|local_max")
        ->check(CLI::IsMember({"iterative", "local_max"}))
        ->capture_default_str();
  }

  sal::IttiParams itti() const {
    sal::IttiParams p;
    p.use_colour = colour;
    p.structure_feature = structure == "slope" ? sal::StructureFeature::kSlope : sal::StructureFeature::kHeight;
    p.normalisation = normalisation == "local_max" ? sal::Normalisation::kLocalMax : sal::Normalisation::kIterative;
    p.weights = {w_intensity, w_orientation, colour ? w_colour : 0.0, w_structure};
    return p;
  }
  sal::ContrastParams contrast() const { return sal::ContrastParams{contrast_sigma, contrast_smooth}; }
  sal::PostProcessParams post(sal::Method m) const {
    sal::PostProcessParams p = m == sal::Method::kContrast ? sal::contrast_post_processing() : sal::PostProcessParams{};
    p.threshold_scale = threshold_scale.value_or(p.threshold_scale);
    p.min_area = min_area.value_or(p.min_area);
    p.open_radius = open_radius;
    p.close_radius = close_radius;
    p.max_detections = max_detections;
    return p;
  }
};

// Returns an empty function when SfS is not compiled in.
sal::HeightFn make_height_fn(int downsample, double slant_deg, std::shared_ptr<void>& keep_alive) {
#ifdef REGOLITH_HAVE_SFS
  sal::SfsHeightParams hp;
  hp.downsample_levels = downsample;
  if (slant_deg < 0.0)
    hp.slant_rad.reset();
  else
    hp.slant_rad = slant_deg * 3.14159265358979323846 / 180.0;
  try {
    hp.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(e.what());
  }
  auto h = std::make_shared<sal::SfsHeight>(hp);
  keep_alive = h;
  return h->function();
#else
  (void)downsample;
  (void)slant_deg;
  (void)keep_alive;
  return {};
#endif
}

[[noreturn]] void no_sfs() {
  throw ConfigError(
      "--method sams needs the shape-from-shading height map, "
      "but this build of regolith has no "
      "regolith::sfs (the SAMS structure channel); use itti, "
      "contrast, spectral_residual or fine_grained");
}

void ensure_dir(const std::string& dir, const char* option) {
  if (!dir.empty()) make_output_dir(dir, std::string("the ") + option + " directory");
}

cv::Mat to_bgr8(const cv::Mat& img) {
  const cv::Mat f = regolith::to_8bit(img);
  cv::Mat out;
  if (f.channels() == 1)
    cv::cvtColor(f, out, cv::COLOR_GRAY2BGR);
  else if (f.channels() == 4)
    cv::cvtColor(f, out, cv::COLOR_BGRA2BGR);
  else
    out = f;
  return out;
}

// A failed input (a directory without images, an unreadable image) is skipped: counted in `count`, its error kept in
// `first_error` when it is the first, and printed.
void skip_input(const sal::DataError& e, int& count, std::string& first_error) {
  ++count;
  if (first_error.empty()) first_error = e.what();
  std::cerr << "error: " << e.what() << " (skipped)\n";
}

// The images of the inputs. A directory stands for the images in it (sorted by name, not recursing); one without any
// is a failed input like an unreadable image (counted in `bad_dirs`), and the others are still processed.
std::vector<std::string> list_inputs(const std::vector<std::string>& args, int& bad_dirs, std::string& first_error) {
  std::vector<std::string> images;
  for (const std::string& a : args) {
    std::error_code ec;
    if (!fs::is_directory(a, ec)) {
      images.push_back(a);
      continue;
    }
    try {
      const std::vector<std::string> in_dir = sal::list_images(a);
      if (in_dir.empty())
        throw sal::DataError(a + ": a directory without an image regolith reads (PNG, JPEG, TIFF, BMP, PNM, WebP)");
      images.insert(images.end(), in_dir.begin(), in_dir.end());
    } catch (const sal::DataError& e) {
      skip_input(e, bad_dirs, first_error);
    }
  }
  return images;
}

// What the method needs, validated: the trained model and its candidate extractor, or the saliency method with its
// parameters (and for SAMS the SfS height map); the post-processing into boxes.
struct RockMethod {
  bool trained = false;
  std::optional<sal::TrainedModel> model;
  std::unique_ptr<sal::CandidateExtractor> extractor;
  sal::Method method = sal::Method::kContrast;
  sal::PostProcessParams post;
  sal::IttiParams ip;
  sal::ContrastParams cp;
  std::shared_ptr<void> keep;  // owns what `height` calls
  sal::HeightFn height;
};

// The method of the options (InputError for a model that does not load, ConfigError for bad parameters or SAMS
// without SfS).
RockMethod configure(const RockOptions& o) {
  RockMethod m;
  m.trained = o.method == "trained";
  if (m.trained) {
    const std::string path = o.model.empty() ? sal::default_trained_model_path() : o.model;
    try {
      m.model = sal::load_trained_model(path);
    } catch (const sal::ModelError& e) {
      throw InputError(e.what());
    }
    m.extractor = std::make_unique<sal::CandidateExtractor>(m.model->candidates);
  }
  m.method = m.trained ? sal::Method::kContrast : sal::method_from_string(o.method);
  m.post = o.post(m.method);
  m.ip = o.itti();
  m.cp = o.contrast();
  try {
    m.post.validate();
    m.ip.validate();
    m.cp.validate();
  } catch (const std::invalid_argument& e) {
    throw ConfigError(e.what());
  }
  if (m.method == sal::Method::kSams) {
    m.height = make_height_fn(o.sfs_downsample, o.sfs_slant_deg, m.keep);
    if (!m.height) no_sfs();
  }
  return m;
}

// The CSV with its header line, after the overlay and saliency directories (created when asked for).
std::ofstream open_outputs(const std::string& csv_path, const std::string& overlay_dir,
                           const std::string& saliency_dir) {
  ensure_dir(overlay_dir, "--overlay-dir");
  ensure_dir(saliency_dir, "--saliency-dir");
  std::ofstream csv(csv_path);
  if (!csv) throw ConfigError("--csv: cannot write '" + csv_path + "'");
  csv << "image,xmin,ymin,xmax,ymax,score\n";
  return csv;
}

// The saliency of an OpenCV peer method (spectral_residual, fine_grained); none for the others.
std::unique_ptr<sal::OpenCvSaliency> make_peer(sal::Method method) {
  if (method == sal::Method::kSpectralResidual || method == sal::Method::kFineGrained) {
    return std::make_unique<sal::OpenCvSaliency>(method);
  }
  return nullptr;
}

// The method's detectors and their buffers, reused from image to image.
struct RockDetectors {
  explicit RockDetectors(const RockMethod& m)
      : itti(m.ip), contrast(m.cp), peer(make_peer(m.method)), detector(m.post) {}

  sal::IttiSaliency itti;
  sal::ContrastSaliency contrast;
  std::unique_ptr<sal::OpenCvSaliency> peer;  // spectral_residual, fine_grained
  sal::BoxDetector detector;
  sal::CandidateSet cand_set;
  cv::Mat map, map8, h, enlarged, full_map;
  std::vector<sal::Detection> dets;
  std::vector<int> spans;  // TrainedModel::score_map's scratch
  sal::TrainedModel::BoxScratch box_scratch;
  cv::Mat unit, intensity;             // the trained map's guide
  sal::TrainedMapScratch map_scratch;  // the trained map's filter and pixel stage
  std::string enlarged_note;           // set by the first image processed enlarged (said once per run)
};

// SAMS and Itti-Koch build a pyramid of 2^(centre_max + delta_max) px a side (256 px by default). A smaller image
// (a 320x240 navigation camera's frame) is processed enlarged to that side, and its map is brought back to the
// image's size, so boxes, minimum areas and the CSV stay in the image's pixels.
const cv::Mat& pyramid_input(const RockMethod& m, RockDetectors& d, const cv::Mat& img, const std::string& path) {
  cv::Size size;
  try {
    size = m.ip.input_size(img.size());
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string(e.what()) + " (use --method contrast or trained)");
  }
  if (size == img.size()) return img;
  const int need = m.ip.min_input_side();
  cv::resize(img, d.enlarged, size, 0, 0, cv::INTER_LINEAR);
  if (d.enlarged_note.empty())
    d.enlarged_note =
        path + " is " + std::to_string(img.cols) + "x" + std::to_string(img.rows) + " px, less than the " +
        std::to_string(need) + " px a side the " + std::to_string(m.ip.max_level() + 1) +
        "-level pyramid needs: such images are processed enlarged (this one to " + std::to_string(size.width) + "x" +
        std::to_string(size.height) + "); boxes are in the image's pixels";
  return d.enlarged;
}

// The boxes of one image in d.dets, and its saliency map in d.map (trained: when `want_map` or the model refines
// its boxes on the map). DataError naming `path` when the method fails on the image.
void detect_rocks(const RockMethod& m, RockDetectors& d, const cv::Mat& img, const std::string& path, bool want_map) {
  try {
    if (m.trained) {
      m.extractor->extract(img, d.cand_set);
      const std::vector<float> scores = m.model->score(d.cand_set);
      if (want_map || m.model->box.refine_fraction > 0.0)
        sal::TrainedModel::score_map(d.cand_set, scores, d.map, d.spans);
      sal::TrainedModel::boxes(d.cand_set, scores, d.map, m.model->box, d.dets, d.box_scratch);
      if (want_map) {
        sal::to_unit_float(img, d.unit);
        sal::intensity_of(d.unit, d.intensity);
        m.model->finish_map(d.intensity, d.map, d.map_scratch);
      }
    } else if (d.peer) {
      d.peer->compute(img, d.map);
    } else if (m.method == sal::Method::kContrast) {
      d.contrast.compute(img, d.map);
    } else {  // SAMS, Itti-Koch
      const cv::Mat& in = pyramid_input(m, d, img, path);
      if (m.method == sal::Method::kSams) {
        m.height(in, d.h);
        d.itti.compute(in, d.h, d.map);
      } else {
        d.itti.compute(in, cv::Mat(), d.map);
      }
      if (in.size() != img.size()) {
        cv::resize(d.map, d.full_map, img.size(), 0, 0, cv::INTER_AREA);
        std::swap(d.map, d.full_map);
      }
    }
  } catch (const std::exception& e) {
    throw sal::DataError(path + ": " + e.what());
  }
  if (!m.trained) d.detector.detect(d.map, d.dets);
}

// The CSV lines of one image: one per box.
void write_boxes(std::ostream& csv, const std::string& name, const std::vector<sal::Detection>& dets) {
  for (const auto& d : dets) {
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.6f", d.score);
    csv << name << ',' << d.box.x << ',' << d.box.y << ',' << d.box.x + d.box.width << ',' << d.box.y + d.box.height
        << ',' << buf << '\n';
  }
}

// <saliency_dir>/<stem>.png: the saliency map in 8 bits (converted into `map8`).
void write_saliency(const cv::Mat& map, cv::Mat& map8, const std::string& saliency_dir, const std::string& stem) {
  sal::to_8bit(map, map8);
  const std::string out = (fs::path(saliency_dir) / (stem + ".png")).string();
  if (!cv::imwrite(out, map8)) throw sal::DataError(out + ": cannot write saliency map");
}

// The ground truth drawn on the overlay `ov` of an image of `size`: cyan outlines of the components of the mask
// <masks_dir>/<stem>.png; returns the number of rocks it holds.
std::size_t draw_truth(cv::Mat& ov, cv::Size size, const std::string& masks_dir, const std::string& stem) {
  const sal::FrameTruth truth = sal::read_truth((fs::path(masks_dir) / (stem + ".png")).string(), size, 0);
  std::vector<std::vector<cv::Point>> contours;  // of the mask read_truth decoded (255 = rock), not a second read
  cv::findContours(truth.mask, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);
  cv::drawContours(ov, contours, -1, cv::Scalar(255, 255, 0), 1, cv::LINE_AA);
  return truth.objects.size();
}

// <overlay_dir>/<stem>.png: the image with the boxes coloured by score and, when masks are given, the ground truth
// under them; a legend strip at the bottom.
void write_overlay(const cv::Mat& img, const std::vector<sal::Detection>& dets, const std::string& masks_dir,
                   const std::string& overlay_dir, const std::string& stem) {
  cv::Mat ov = to_bgr8(img).clone();
  std::string legend = "boxes: score red 0 -> green 1";
  if (!masks_dir.empty()) {
    const std::size_t rocks = draw_truth(ov, img.size(), masks_dir, stem);
    legend += "; ground truth: cyan (" + std::to_string(rocks) + " rocks)";
  }
  for (const auto& d : dets) {
    const double sc = std::clamp(static_cast<double>(d.score), 0.0, 1.0);
    const cv::Scalar colour(0, 255.0 * sc, 255.0 * (1.0 - sc));
    cv::rectangle(ov, d.box, colour, 2);
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.2f", d.score);
    cv::putText(ov, buf, cv::Point(d.box.x + 2, std::max(12, d.box.y - 3)), cv::FONT_HERSHEY_SIMPLEX, 0.4, colour, 1);
  }
  cv::rectangle(ov, cv::Rect(0, ov.rows - 18, ov.cols, 18), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(ov, legend, cv::Point(4, ov.rows - 5), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  const std::string out = (fs::path(overlay_dir) / (stem + ".png")).string();
  if (!cv::imwrite(out, ov)) throw sal::DataError(out + ": cannot write overlay");
}

// `regolith rocks`: the boxes of every image in the CSV (and its overlay and saliency map when asked for); InputError
// after the others when an input failed.
void run_rocks(const std::vector<std::string>& args, const RockOptions& o, const std::string& csv_path,
               const std::string& overlay_dir, const std::string& saliency_dir, const std::string& masks_dir) {
  int bad_dirs = 0;
  std::string first_error;
  const std::vector<std::string> images = list_inputs(args, bad_dirs, first_error);
  const RockMethod m = configure(o);
  std::ofstream csv = open_outputs(csv_path, overlay_dir, saliency_dir);
  RockDetectors d(m);
  int failed = 0;
  size_t total_boxes = 0;
  double detect_s = 0.0;  // wall time of map / candidates + boxes, decoding excluded
  double first_s = 0.0;   // of it, the first image's (which also makes the detector's buffers)
  int detected = 0;
  for (const std::string& path : images) {
    try {
      const cv::Mat img = sal::read_image(path);
      const auto t0 = std::chrono::steady_clock::now();
      detect_rocks(m, d, img, path, !saliency_dir.empty());
      const double took = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      if (detected == 0) first_s = took;
      detect_s += took;
      ++detected;
      const std::string stem = fs::path(path).stem().string();
      write_boxes(csv, fs::path(path).filename().string(), d.dets);
      total_boxes += d.dets.size();
      if (!saliency_dir.empty()) write_saliency(d.map, d.map8, saliency_dir, stem);
      if (!overlay_dir.empty()) write_overlay(img, d.dets, masks_dir, overlay_dir, stem);
    } catch (const sal::DataError& e) {
      skip_input(e, failed, first_error);
    }
  }
  close_output(csv, csv_path, "the rocks CSV");
  if (!d.enlarged_note.empty()) std::cerr << "rocks: note: " << d.enlarged_note << "\n";
  // The first image also allocates what every later one reuses (buffers sized for the image and
  // the most candidates it can give): its time is shown apart, the warm rate after it.
  const auto ms = [](double seconds) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f", 1e3 * seconds);
    return std::string(b);
  };
  std::cerr << "rocks: " << images.size() - static_cast<size_t>(failed) << " image(s), " << total_boxes
            << " box(es) -> " << csv_path << " (" << o.method << ": " << ms(detected ? detect_s / detected : 0.0)
            << " ms per image, decoding excluded";
  if (detected > 1)
    std::cerr << "; " << ms((detect_s - first_s) / (detected - 1)) << " ms per image after the first, whose "
              << ms(first_s) << " ms include making the detector's buffers";
  else if (detected == 1)
    std::cerr << ", including making the detector's buffers once";
  std::cerr << ")\n";
  if (failed + bad_dirs > 0) {
    throw InputError(std::to_string(failed + bad_dirs) + " of " +
                     std::to_string(images.size() + static_cast<size_t>(bad_dirs)) +
                     " input(s) failed; first: " + first_error);
  }
}

struct EvalOptions {
  std::string images, masks;
  std::vector<std::string> methods;
  bool sweep = false;
  int min_gt_area = 50;
  int folds = 5;
  double weight_step = 0.1;
  std::vector<double> scales{0.8, 1.0, 1.2, 1.4};
  // The contrast grid of the sweep / CV (defaults: sal::StudyConfig).
  std::vector<double> contrast_sigmas = sal::StudyConfig{}.contrast_sigmas;
  std::vector<double> contrast_smooths = sal::StudyConfig{}.contrast_smooth_sigmas;
  std::vector<double> contrast_scales = sal::StudyConfig{}.contrast_threshold_scales;
  std::vector<int> contrast_min_areas = sal::StudyConfig{}.contrast_min_areas;
  std::string markdown;
  bool trained_cv = false;
  uint64_t train_seed = sal::TrainParams{}.seed;
};

// Reads every image / mask pair and extracts + labels the trained method's candidates. The
// working width (`cp.working_width_px`, when 0) becomes the images' median width: the model's
// pixel scales and box-size features then mean the same on images of another size.
std::vector<sal::LabelledFrame> load_labelled(const std::string& images, const std::string& masks, int min_gt_area,
                                              sal::CandidateParams& cp, const sal::TrainParams& tp, int& failed,
                                              std::vector<sal::DatasetItem>* items_out = nullptr) {
  sal::DatasetListing listing = sal::list_dataset(images, masks);
  failed = static_cast<int>(listing.errors.size());
  for (const auto& err : listing.errors) std::cerr << "error: " << err << " (skipped)\n";
  if (cp.working_width_px == 0) cp.working_width_px = sal::median_image_width(listing.items);
  sal::CandidateExtractor extractor(cp);
  std::vector<sal::LabelledFrame> frames;
  for (const auto& item : listing.items) {
    try {
      frames.push_back(sal::make_labelled_frame(item, extractor, min_gt_area, tp.positive_iou));
      if (items_out) items_out->push_back(item);
    } catch (const sal::DataError& ex) {
      ++failed;
      std::cerr << "error: " << ex.what() << " (skipped)\n";
    }
  }
  if (frames.empty()) throw InputError(images + ": no usable image/mask pairs");
  return frames;
}

void run_train(const std::string& images, const std::string& masks, const std::string& out, int min_gt_area) {
  // checked before the images are read and the forest trained, not after
  if (const std::filesystem::path dir = std::filesystem::path(out).parent_path();
      !dir.empty() && !std::filesystem::is_directory(dir))
    throw InputError(out + ": cannot write the rock model file (no directory " + dir.string() + ")");
  sal::CandidateParams cp;
  const sal::TrainParams tp;
  int failed = 0;
  const auto frames = load_labelled(images, masks, min_gt_area, cp, tp, failed);
  std::vector<const sal::LabelledFrame*> ptrs;
  for (const auto& f : frames) ptrs.push_back(&f);
  sal::TrainedModel m;
  try {
    m = sal::train_model(ptrs, cp, tp);
  } catch (const std::invalid_argument& ex) {
    throw InputError(images + ": " + ex.what());
  }
  try {
    sal::save_trained_model(m, out);
  } catch (const sal::ModelError& ex) {
    throw InputError(ex.what());
  }
  std::cerr << "train rocks: " << m.training_images << " image(s), " << m.training_samples << " candidates ("
            << m.training_positives << " positive); " << kBoxTextFields << ": " << box_text(m.box)
            << (m.has_pixel_stage() ? "; with a pixel stage" : "; no pixel stage (a single sol group)") << " -> " << out
            << '\n';
  if (failed > 0) throw InputError(std::to_string(failed) + " image(s) skipped (see the errors above)");
}

// image file name -> subset from a dataset's manifest.csv (columns `image` and `subset`, the
// image possibly with a directory); empty when there is no such file or column.
std::map<std::string, std::string> read_subsets(const std::filesystem::path& manifest) {
  std::map<std::string, std::string> out;
  if (!std::filesystem::exists(manifest)) return out;
  const CsvTable t = CsvTable::read(manifest.string());
  if (t.column("image") < 0 || t.column("subset") < 0) return out;
  for (std::size_t i = 0; i < t.size(); ++i)
    if (!t.text(i, "image").empty())
      out[std::filesystem::path(t.text(i, "image")).filename().string()] = t.text(i, "subset");
  return out;
}

// `eval rocks --trained-cv`: the trained method scored by grouped k-fold CV (models trained
// only on the other folds), next to the contrast method with its defaults on the same folds.
std::string mean_std(const std::vector<double>& v) {
  const double m = std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  double s2 = 0.0;
  for (double x : v) s2 += (x - m) * (x - m);
  const double sd = v.size() > 1 ? std::sqrt(s2 / static_cast<double>(v.size() - 1)) : 0.0;
  char buf[64];
  std::snprintf(buf, sizeof buf, "%.3f ± %.3f", m, sd);
  return buf;
}

// An evaluation's markdown on stdout and in `path` (if given); an error after both when
// `failed` images were skipped, so a partial report is never mistaken for a whole one.
void publish_report(const std::string& md, const std::string& path, int failed) {
  std::cout << md;
  if (!path.empty()) {
    write_file(path, md, "the report");
  }
  if (failed > 0) throw InputError(std::to_string(failed) + " image(s) skipped (see the errors above)");
}

void run_trained_cv(const EvalOptions& e, const RockOptions& o) {
  sal::CandidateParams cp;
  sal::TrainParams tp;
  tp.seed = e.train_seed;
  int failed = 0;
  std::vector<sal::DatasetItem> items;
  const auto frames = load_labelled(e.images, e.masks, e.min_gt_area, cp, tp, failed, &items);
  // Contrast with its defaults (every fold of its own grouped CV chose them).
  sal::ContrastSaliency contrast(o.contrast());
  sal::BoxDetector detector(o.post(sal::Method::kContrast));
  std::vector<sal::FrameRecord> crec;
  cv::Mat map, map8;
  std::vector<sal::Detection> dets;
  for (size_t i = 0; i < frames.size(); ++i) {
    contrast.compute(sal::read_image(items[i].image_path), map);
    detector.detect(map, dets);
    sal::to_8bit(map, map8);
    crec.push_back(sal::evaluate_frame(frames[i].name, dets, frames[i].truth, map8));
  }
  const sal::TrainedCvResult r = sal::cross_validate_trained(frames, cp, tp, e.folds);
  std::ostringstream md;
  md << "### Trained method: " << e.folds
     << "-fold cross-validation grouped by sol (each fold scored by a model "
        "trained on the other folds only)\n\nImages: "
     << frames.size() << " (" << failed << " skipped), GT components >= " << e.min_gt_area << " px.\n\n"
     << sal::markdown_table({{"contrast (defaults)", sal::summarise(crec)},
                             {"trained, map before the pixel stage", sal::summarise(r.pooled_guided)},
                             {"trained", sal::summarise(r.pooled)}})
     << "\n| test fold | images | GT | contrast N-MODA@0.2 / @0.5 / max F | "
        "trained N-MODA@0.2 / @0.5 / max F | trained boxes | chosen "
     << kBoxTextFields << " |\n|---:|---:|---:|---|---|---:|---|\n";
  for (int f = 0; f < e.folds; ++f) {
    std::vector<size_t> idx;
    for (size_t i = 0; i < frames.size(); ++i)
      if (r.fold_of[i] == f) idx.push_back(i);
    const sal::Summary c = sal::summarise(crec, idx);
    const sal::Summary t = r.fold_summaries[static_cast<size_t>(f)];
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "| %d | %d | %d | %.3f / %.3f / %.3f | %.3f / %.3f / %.3f | "
                  "%d | %s |\n",
                  f + 1, t.images, t.gt, c.n_moda02, c.n_moda05, c.max_f, t.n_moda02, t.n_moda05, t.max_f, t.boxes,
                  box_text(r.box_params[static_cast<size_t>(f)]).c_str());
    md << buf;
  }
  // Per subset, when the dataset has a manifest.csv (image,...,subset,...) beside the image
  // directory: the held-out goal is to lead the contrast peer on each subset.
  const std::map<std::string, std::string> subsets =
      read_subsets(std::filesystem::path(e.images).parent_path() / "manifest.csv");
  if (!subsets.empty()) {
    std::map<std::string, std::vector<size_t>> by;
    for (size_t i = 0; i < frames.size(); ++i) {
      const auto it = subsets.find(frames[i].name);
      by[it == subsets.end() ? std::string("(not listed)") : it->second].push_back(i);
    }
    md << "\n| subset | images | GT | contrast N-MODA@0.2 / @0.5 / max F | trained "
          "N-MODA@0.2 / @0.5 / max F |\n|---|---:|---:|---|---|\n";
    for (const auto& [name, idx] : by) {
      const sal::Summary c = sal::summarise(crec, idx), t = sal::summarise(r.pooled, idx);
      char buf[256];
      std::snprintf(buf, sizeof buf, "| %s | %d | %d | %.3f / %.3f / %.3f | %.3f / %.3f / %.3f |\n", name.c_str(),
                    t.images, t.gt, c.n_moda02, c.n_moda05, c.max_f, t.n_moda02, t.n_moda05, t.max_f);
      md << buf;
    }
  }
  // Upper bound set by the candidates: GT components with a candidate at IoU >= 0.2 / 0.5.
  int n_gt = 0, cover02 = 0, cover05 = 0;
  size_t n_cand = 0;
  for (const auto& f : frames) {
    n_cand += f.set.candidates.size();
    for (const auto& g : f.truth.objects) {
      if (g.ignored) continue;
      ++n_gt;
      double best = 0.0;
      for (const auto& c : f.set.candidates) best = std::max(best, sal::iou(c.box, g.box));
      cover02 += best >= 0.2;
      cover05 += best >= 0.5;
    }
  }
  md << "\nCandidates: " << n_cand << " (" << n_cand / frames.size()
     << " per image); GT components with a candidate at IoU >= 0.2: " << cover02 << " of " << n_gt
     << ", at IoU >= 0.5: " << cover05 << " (the recall the ranking stage cannot exceed).\n";
  publish_report(md.str(), e.markdown, failed);
}

// The study's settings from the command line (ConfigError naming the bad one).
sal::StudyConfig study_config(const EvalOptions& e, const RockOptions& o) {
  sal::StudyConfig cfg;
  cfg.itti = o.itti();
  cfg.itti_weights = {1.0, 1.0, o.colour ? 1.0 : 0.0, 0.0};
  cfg.post = o.post(sal::Method::kSams);
  cfg.min_gt_area = e.min_gt_area;
  cfg.folds = e.folds;
  cfg.weight_step = e.weight_step;
  cfg.threshold_scales = e.scales;
  cfg.contrast = o.contrast();
  cfg.contrast_post = o.post(sal::Method::kContrast);
  cfg.contrast_sigmas = e.contrast_sigmas;
  cfg.contrast_smooth_sigmas = e.contrast_smooths;
  cfg.contrast_threshold_scales = e.contrast_scales;
  cfg.contrast_min_areas = e.contrast_min_areas;
  try {
    cfg.validate();
  } catch (const std::invalid_argument& ex) {
    throw ConfigError(ex.what());
  }
  return cfg;
}

// Every readable image/mask pair into the study; the others are reported and counted.
int add_pairs(sal::RockStudy& study, const EvalOptions& e) {
  sal::DatasetListing listing = sal::list_dataset(e.images, e.masks);
  int failed = static_cast<int>(listing.errors.size());
  for (const auto& err : listing.errors) std::cerr << "error: " << err << " (skipped)\n";
  for (const auto& item : listing.items) {
    try {
      study.add(item);
    } catch (const sal::DataError& ex) {
      ++failed;
      std::cerr << "error: " << ex.what() << " (skipped)\n";
    }
  }
  if (study.size() == 0) throw InputError(e.images + ": no usable image/mask pairs");
  return failed;
}

// The SAMS weight grid on all images (optimistic: chosen on the images it is scored on).
void write_weight_sweep(std::ostream& md, sal::RockStudy& study, double weight_step) {
  const auto cands = study.candidates(sal::Method::kSams, true, false);
  const auto sweep = study.sweep(sal::Method::kSams, cands);
  md << "### SAMS weight sweep on all " << study.size() << " images (" << cands.size() << " weight combinations, step "
     << weight_step << ", fixed post-processing), top 10\n\n"
     << "| rank | weights | N-MODA@0.2 | N-MODA@0.5 | P@0.2 | R@0.2 | "
        "boxes |\n"
     << "|---:|---|---:|---:|---:|---:|---:|\n";
  for (size_t k = 0; k < std::min<size_t>(10, sweep.size()); ++k) {
    const auto& s = sweep[k].summary;
    char buf[256];
    std::snprintf(buf, sizeof buf, "| %zu | %s | %.3f | %.3f | %.3f | %.3f | %d |\n", k + 1,
                  sweep[k].candidate.describe(sal::Method::kSams).c_str(), s.n_moda02, s.n_moda05, s.precision02,
                  s.recall02, s.boxes);
    md << buf;
  }
  md << "\nBest on the full set (optimistic, selected on the same images): "
     << sweep.front().candidate.describe(sal::Method::kSams) << "\n\n";
}

// The folds, grouped by sol (every image of a sol in one fold).
void write_folds(std::ostream& md, const sal::RockStudy& study, int folds) {
  const std::vector<int> fold_of = study.folds();
  md << "### Folds (grouped by sol: every image of one sol in the same fold)\n\n"
     << "| fold | images | sols |\n|---:|---:|---|\n";
  for (int f = 0; f < folds; ++f) {
    std::vector<std::string> sols;
    size_t count = 0;
    for (size_t i = 0; i < study.size(); ++i) {
      if (fold_of[i] != f) continue;
      ++count;
      if (std::find(sols.begin(), sols.end(), study.group(i)) == sols.end()) sols.push_back(study.group(i));
    }
    md << "| " << f + 1 << " | " << count << " | ";
    for (size_t j = 0; j < sols.size(); ++j) md << (j ? ", " : "") << sols[j];
    md << " |\n";
  }
  md << '\n';
}

// Grouped k-fold cross-validation of every method, once with the Otsu scales fixed and once
// (given two or more scales) with them chosen on the train folds too.
void write_cross_validation(std::ostream& md, sal::RockStudy& study, const std::vector<sal::Method>& methods,
                            const sal::StudyConfig& cfg) {
  // The contrast grid does not depend on tune_scales: cross-validated once.
  std::optional<sal::CvResult> contrast_cv;
  for (bool tune_scales : {false, true}) {
    if (tune_scales && cfg.threshold_scales.size() < 2) continue;
    std::vector<std::pair<std::string, sal::Summary>> cv_rows;
    std::ostringstream folds_md, per_fold_md;
    for (sal::Method m : methods) {
      const bool own_grid = m == sal::Method::kSams || m == sal::Method::kContrast;
      sal::CvResult r;
      if (m == sal::Method::kContrast && contrast_cv) {
        r = *contrast_cv;
      } else {
        r = study.cross_validate(m, study.candidates(m, own_grid, tune_scales));
        if (m == sal::Method::kContrast) contrast_cv = r;
      }
      cv_rows.emplace_back(sal::to_string(m), sal::summarise(r.pooled));
      std::vector<double> maxf;
      for (const auto& s : r.fold_summaries) maxf.push_back(s.max_f);
      folds_md << "| " << sal::to_string(m) << " | " << mean_std(r.fold_moda02) << " | " << mean_std(r.fold_moda05)
               << " | " << mean_std(maxf) << " | " << r.most_chosen().describe(m) << " |\n";
      for (size_t f = 0; f < r.fold_summaries.size(); ++f) {
        const auto& s = r.fold_summaries[f];
        char buf[128];
        std::snprintf(buf, sizeof buf, "| %d | %d | %.3f | %.3f | %.3f | ", s.images, s.gt, s.n_moda02, s.n_moda05,
                      s.max_f);
        per_fold_md << "| " << sal::to_string(m) << " | " << f + 1 << ' ' << buf << r.chosen[f].describe(m) << " |\n";
      }
    }
    md << "### " << cfg.folds << "-fold cross-validation grouped by sol: "
       << (tune_scales ? "SAMS weights, the contrast grid and every other "
                         "method's Otsu scale"
                       : "SAMS weights and the contrast grid (Otsu x1 for "
                         "the others)")
       << " chosen on the train folds; test folds pooled\n\n"
       << sal::markdown_table(cv_rows) << "\n| method | test-fold N-MODA@0.2 (mean ± sd) | "
       << "test-fold N-MODA@0.5 (mean ± sd) | test-fold max F (mean ± sd) | "
          "chosen in most folds |\n|---|---|---|---|---|\n"
       << folds_md.str()
       << "\n| method | test fold | images | GT | N-MODA@0.2 | N-MODA@0.5 | "
          "max F | chosen on the other folds |\n"
          "|---|---:|---:|---:|---:|---:|---:|---|\n"
       << per_fold_md.str() << '\n';
  }
}

void run_eval(const EvalOptions& e, const RockOptions& o) {
  if (e.trained_cv) {
    run_trained_cv(e, o);
    return;
  }
  std::vector<sal::Method> methods;
  for (const auto& m : e.methods) methods.push_back(sal::method_from_string(m));
  if (methods.empty()) methods.assign(sal::kAllMethods.begin(), sal::kAllMethods.end());
  const sal::StudyConfig cfg = study_config(e, o);
  std::shared_ptr<void> keep;
  sal::HeightFn height = make_height_fn(o.sfs_downsample, o.sfs_slant_deg, keep);
  const bool want_sams = std::find(methods.begin(), methods.end(), sal::Method::kSams) != methods.end();
  if (want_sams && !height) no_sfs();
  sal::RockStudy study(cfg, height);
  const int failed = add_pairs(study, e);

  std::ostringstream md;
  md << "Images: " << study.size() << " (" << failed << " skipped), ground-truth components >= " << e.min_gt_area
     << " px, post-processing: Otsu x" << cfg.post.threshold_scale << ", open r=" << cfg.post.open_radius
     << " px, close r=" << cfg.post.close_radius << " px, min area " << cfg.post.min_area
     << " px (contrast: its own Otsu scale and min area, below); Itti/SAMS "
        "colour channel: "
     << (o.colour ? "on" : "off") << ".\n\n";
  std::vector<std::pair<std::string, sal::Summary>> rows;
  for (sal::Method m : methods) {
    rows.emplace_back(sal::to_string(m), sal::summarise(study.evaluate_all(m, study.default_candidate(m), true)));
  }
  md << "### Fixed settings (SAMS " << study.default_candidate(sal::Method::kSams).describe(sal::Method::kSams)
     << "; contrast " << study.default_candidate(sal::Method::kContrast).describe(sal::Method::kContrast) << ")\n\n"
     << sal::markdown_table(rows) << '\n';
  if (e.sweep) {
    if (want_sams) write_weight_sweep(md, study, e.weight_step);
    write_folds(md, study, cfg.folds);
    write_cross_validation(md, study, methods, cfg);
  }
  publish_report(md.str(), e.markdown, failed);
}

}  // namespace

void add_rocks_commands(CLI::App& app) {
  // regolith rocks IMAGE... --method M --csv OUT.csv [--overlay-dir DIR]
  // [--saliency-dir DIR]
  auto* rocks = app.add_subcommand("rocks", "detect rocks (salient objects) in images -> CSV boxes");
  auto images = std::make_shared<std::vector<std::string>>();
  auto ro = std::make_shared<RockOptions>();
  auto csv = std::make_shared<std::string>();
  auto overlay = std::make_shared<std::string>();
  auto saliency_dir = std::make_shared<std::string>();
  auto masks_dir = std::make_shared<std::string>();
  rocks->add_option("images", *images, "input images, or directories of them (sorted by name)")->required();
  ro->add_to(rocks);
  rocks->add_option("--csv", *csv, "output CSV: image,xmin,ymin,xmax,ymax,score")->required();
  rocks->add_option("--overlay,--overlay-dir", *overlay, "write <stem>.png with the boxes drawn (coloured by score)");
  rocks->add_option("--masks", *masks_dir,
                    "with --overlay: draw the ground-truth outlines of "
                    "<masks>/<stem>.png");
  rocks->add_option("--saliency-dir", *saliency_dir, "write <stem>.png 8-bit saliency maps");
  rocks->callback([=] { run_rocks(*images, *ro, *csv, *overlay, *saliency_dir, *masks_dir); });

  // regolith eval rocks --images DIR --masks DIR [--method M]...
  // [--sweep-weights] [--min-gt-area N]
  CLI::App* eval = group(app, "eval", "evaluate algorithms against ground truth");
  auto* er = eval->add_subcommand("rocks", "rock detection scores (N-MODA, N-MODP, P, R, F, MAE)");
  auto eo = std::make_shared<EvalOptions>();
  auto ro2 = std::make_shared<RockOptions>();
  er->add_option("--images", eo->images, "image directory")->required();
  er->add_option("--masks", eo->masks, "mask directory (<stem>.png, nonzero = rock)")->required();
  ro2->add_to(er);
  er->remove_option(er->get_option("--method"));
  er->remove_option(er->get_option("--model"));  // --trained-cv trains its own
  er->add_option("--method", eo->methods, "methods to score (repeatable; default: all)")
      ->check(CLI::IsMember(sal::method_names()));
  er->add_flag("--sweep-weights", eo->sweep,
               "SAMS weight grid (Table 5.2 analogue) and k-fold "
               "cross-validation grouped by sol (SAMS weights, contrast grid, "
               "Otsu scales)");
  er->add_option("--min-gt-area", eo->min_gt_area, "px, ignore smaller mask components")->capture_default_str();
  er->add_option("--folds", eo->folds, "k of the k-fold cross-validation")->capture_default_str();
  er->add_option("--weight-step", eo->weight_step, "grid step of the weight sweep")->capture_default_str();
  er->add_option("--threshold-scales", eo->scales, "Otsu scales tried by the cross-validation")->capture_default_str();
  er->add_option("--contrast-sigmas", eo->contrast_sigmas, "px, contrast surround sigmas tried by the cross-validation")
      ->capture_default_str();
  er->add_option("--contrast-smooths", eo->contrast_smooths,
                 "px, contrast smoothing sigmas tried by the cross-validation")
      ->capture_default_str();
  er->add_option("--contrast-threshold-scales", eo->contrast_scales,
                 "contrast Otsu scales tried by the cross-validation")
      ->capture_default_str();
  er->add_option("--contrast-min-areas", eo->contrast_min_areas,
                 "px, contrast minimum box areas tried by the cross-validation")
      ->capture_default_str();
  er->add_option("--markdown", eo->markdown, "also write the tables to this file");
  er->add_flag("--trained-cv", eo->trained_cv,
               "score only the trained method by grouped k-fold CV (models "
               "trained on the other folds) next to contrast");
  er->add_option("--train-seed", eo->train_seed,
                 "--trained-cv: RNG seed of the random forests (to measure "
                 "the seed-to-seed spread)")
      ->capture_default_str();
  er->callback([=] { run_eval(*eo, *ro2); });

  // regolith train rocks --images DIR --masks DIR --out MODEL
  CLI::App* train = group(app, "train", "train models from labelled data");
  auto* tr = train->add_subcommand("rocks", "train the rock ranking model of `regolith rocks --method trained`");
  auto ti = std::make_shared<std::string>();
  auto tm = std::make_shared<std::string>();
  auto to = std::make_shared<std::string>();
  auto tmin = std::make_shared<int>(50);
  tr->add_option("--images", *ti, "image directory")->required();
  tr->add_option("--masks", *tm, "mask directory (<stem>.png, nonzero = rock)")->required();
  tr->add_option("--out", *to, "model file to write (YAML)")->required();
  tr->add_option("--min-gt-area", *tmin, "px, ignore smaller mask components")->capture_default_str();
  tr->callback([=] { run_train(*ti, *tm, *to, *tmin); });
}

namespace {
[[maybe_unused]] const bool registered = add_command(add_rocks_commands);
}  // namespace

}  // namespace regolith::cli
