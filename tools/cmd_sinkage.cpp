// `regolith calibrate sinkage FRAME.png --angle RAD`: wheel-leg geometry from a frame of the
// un-sunk wheel, printed as the YAML `geometry:` block of the wheel_sinkage component.
// `regolith eval sinkage`: the thesis Table 4.1 analogue (load x illumination; mean / max error in
// mm and in % of ground truth) from recorded image sequences (CSV frame,encoder_angle_rad,truth_mm),
// bench-rig logs written by the component (vision vs linear transducer), or four synthetic
// sequences generated here (--synthetic).
// Algorithms: components/sinkage; synthetic scenes: mocks/wheel_scene (optional: without it
// --synthetic fails with a message).
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/params.hpp"
#include "regolith/sinkage/bench_log.hpp"
#include "regolith/sinkage/sinkage.hpp"

#ifdef REGOLITH_HAVE_WHEEL_SCENE
#include "regolith/wheel_scene/sinkage_setup.hpp"
#endif
#ifdef REGOLITH_HAVE_SINKAGE_COMPONENT
#include "regolith/sinkage/component.hpp"
#endif

namespace regolith::cli {

void add_sinkage_commands(CLI::App& app);

namespace {

namespace fs = std::filesystem;
namespace sk = regolith::sinkage;

// ---- calibrate sinkage ------------------------------------------------------------------------

struct CalibrateOptions {
  std::string frame;
  double angle_rad = 0.0;
  int leg_count = 5;
  double spacing_rad = 0.0;  // 0 = 2 pi / leg_count
  int direction = 1;
  std::string segmentation = "auto";
  double hue_min = 195.0, hue_max = 255.0, sat_min = 0.35, val_min = 0.20;
  int min_leg_area = 200;
  std::string overlay;
};

void run_calibrate(const CalibrateOptions& o) {
  std::string why;
  const cv::Mat bgr = regolith::read_image_8bit(o.frame, cv::IMREAD_COLOR, &why);
  if (bgr.empty()) throw InputError(o.frame + ": cannot read image: " + why);
  sk::CalibrationHints h;
  h.leg_count = o.leg_count;
  h.leg_spacing_rad = o.spacing_rad > 0 ? o.spacing_rad : 2.0 * std::numbers::pi / o.leg_count;
  h.rotation_direction = o.direction;
  h.colour.mode = o.segmentation == "hsv"        ? sk::SegmentationMode::kHsv
                  : o.segmentation == "adaptive" ? sk::SegmentationMode::kAdaptive
                                                 : sk::SegmentationMode::kAuto;
  h.colour.hue_min_deg = o.hue_min;
  h.colour.hue_max_deg = o.hue_max;
  h.colour.sat_min = o.sat_min;
  h.colour.val_min = o.val_min;
  h.min_leg_area_px = o.min_leg_area;
  sk::CalibrationReport rep;
  try {
    rep = sk::calibrate_from_unsunk_frame(bgr, o.angle_rad, h);
  } catch (const std::exception& e) {
    throw InputError(o.frame + ": calibration failed: " + e.what());
  }
  std::cout << "# regolith calibrate sinkage " << o.frame << " --angle " << o.angle_rad << " (" << bgr.cols << "x"
            << bgr.rows << " px): " << rep.legs_used << " legs, hub fit rms " << rep.hub_fit_rms_px << " px\n"
            << sk::geometry_to_yaml(rep.geometry, 0);
  if (!o.overlay.empty()) {
    sk::SinkageParams p;
    p.mode = h.colour.mode;
    sk::SinkageEstimator est(rep.geometry, p, bgr.size());
    sk::SinkageResult r;
    est.process(bgr, o.angle_rad, r);
    cv::Mat out;
    sk::draw_overlay(est, bgr, r, out);
    if (!cv::imwrite(o.overlay, out)) throw InputError(o.overlay + ": cannot write the overlay image");
  }
}

// ---- eval sinkage -----------------------------------------------------------------------------

struct EvalOptions {
  std::vector<std::string> sequences;
  std::vector<std::string> logs;
  bool synthetic = false;
  std::string params;
  std::string component;
  int frames = 48;
  double misalignment_deg = 0.0;
  int seed = 1;
  std::string write_dir;
};

/// A condition of the table and its paired samples.
struct Condition {
  std::string load, illumination;
  std::vector<sk::EvalSample> samples;
  std::size_t without_truth = 0;
};

Condition& condition(std::vector<Condition>& rows, const std::string& load, const std::string& light) {
  for (auto& r : rows)
    if (r.load == load && r.illumination == light) return r;
  rows.push_back({load, light, {}, 0});
  return rows.back();
}

struct Algorithm {
  sk::WheelGeometry geometry;
  sk::SinkageParams params;
  bool from_file = false;
};

/// --params FILE: either a mapping with the component's algorithm keys (geometry block + estimator
/// keys) or a deployment, whose `wheel_sinkage` component (or --component NAME) is used.
Algorithm load_algorithm(const EvalOptions& o) {
  Algorithm a;
  if (o.params.empty()) return a;
#ifdef REGOLITH_HAVE_SINKAGE_COMPONENT
  Params root = Params::load_file(o.params);
  if (root.has("components")) {
    Params comps = root.child("components");
    std::string name = o.component;
    if (name.empty()) {
      for (const auto& k : comps.keys()) {
        if (comps.node()[k]["type"] && comps.node()[k]["type"].as<std::string>("") == "wheel_sinkage") {
          name = k;
          break;
        }
      }
      if (name.empty()) root.fail("components", "no component of type wheel_sinkage (use --component NAME)");
    }
    if (!comps.has(name)) comps.fail({}, "no component named '" + name + "'");
    Params c = comps.child(name);
    const sk::AlgorithmConfig cfg = sk::read_algorithm_config(c);
    a.geometry = cfg.geometry;
    a.params = cfg.params;
  } else {
    // Only algorithm keys are allowed in a plain parameter file.
    const sk::AlgorithmConfig cfg = sk::read_algorithm_config(root);
    root.finish();
    a.geometry = cfg.geometry;
    a.params = cfg.params;
  }
  a.from_file = true;
  return a;
#else
  throw ConfigError(o.params + ": --params needs the wheel_sinkage component library in this build");
#endif
}

fs::path sequence_csv(const std::string& arg) {
  const fs::path p(arg);
  if (fs::is_directory(p)) return p / "sequence.csv";
  return p;
}

void eval_sequence(const std::string& arg, const Algorithm& algo, std::vector<Condition>& rows) {
  const fs::path csv = sequence_csv(arg);
  if (!fs::exists(csv)) throw InputError(csv.string() + ": no such file");
#ifdef REGOLITH_HAVE_WHEEL_SCENE
  std::vector<wheel_scene::SequenceRow> seq;
  std::string load, light;
  try {
    seq = wheel_scene::read_sequence_csv(csv);
    load = wheel_scene::read_sequence_comment(csv, "load");
    light = wheel_scene::read_sequence_comment(csv, "illumination");
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  if (seq.empty()) throw InputError(csv.string() + ": no frames");
  if (load.empty()) load = csv.parent_path().filename().string();
  if (light.empty()) light = "-";
  Condition& cond = condition(rows, load, light);
  std::unique_ptr<sk::SinkageEstimator> est;
  sk::SinkageResult r;
  for (const auto& row : seq) {
    fs::path img = row.frame;
    if (img.is_relative()) img = csv.parent_path() / img;
    std::string why;
    const cv::Mat bgr = regolith::read_image_8bit(img.string(), cv::IMREAD_COLOR, &why);
    const std::string where = csv.string() + ":" + std::to_string(row.line) + ": ";
    if (bgr.empty()) throw InputError(where + "cannot read image '" + img.string() + "': " + why);
    if (!est) {
      est = std::make_unique<sk::SinkageEstimator>(algo.geometry, algo.params, bgr.size());
    } else if (bgr.size() != est->image_size()) {
      throw InputError(where + "image '" + img.string() + "' is " + std::to_string(bgr.cols) + "x" +
                       std::to_string(bgr.rows) + ", the sequence's first frame " +
                       std::to_string(est->image_size().width) + "x" + std::to_string(est->image_size().height));
    }
    est->process(bgr, row.encoder_angle_rad, r);
    cond.samples.push_back({row.truth_mm, r.valid ? r.sinkage_mm : 0.0, r.valid});
  }
#else
  (void)algo;
  (void)rows;
  throw InputError(csv.string() + ": reading sequences needs mocks/wheel_scene in this build");
#endif
}

void eval_log(const std::string& file, std::vector<Condition>& rows) {
  std::vector<sk::BenchLogRow> log;
  try {
    log = sk::read_bench_log(file);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  if (log.empty()) throw InputError(file + ": no rows");
  for (const auto& r : log) {
    Condition& c = condition(rows, r.load, r.illumination);
    if (!std::isfinite(r.transducer_mm)) {
      ++c.without_truth;
      continue;
    }
    c.samples.push_back({r.transducer_mm, r.valid ? r.vision_mm : 0.0, r.valid});
  }
}

#ifdef REGOLITH_HAVE_WHEEL_SCENE
void eval_synthetic(const EvalOptions& o, const Algorithm& algo, std::vector<Condition>& rows) {
  struct Load {
    const char* name;
    double max_mm;
  };
  struct Light {
    const char* name;
    const char* dir;
    wheel_scene::Illumination light;
  };
  // Heavier load, deeper sinkage: peak sinkage of the generated profiles.
  const Load loads[] = {{"3.5 kg", 40.0}, {"1.0 kg", 15.0}};
  const Light lights[] = {{"300-400 lux", "normal", wheel_scene::Illumination::normal()},
                          {"10-15 lux", "poor", wheel_scene::Illumination::poor()}};
  int idx = 0;
  for (const Load& l : loads) {
    for (const Light& li : lights) {
      wheel_scene::SceneParams sp;
      sp.light = li.light;
      sp.misalignment_rad = o.misalignment_deg * std::numbers::pi / 180.0;
      sp.seed = static_cast<std::uint32_t>(o.seed + idx);
      wheel_scene::WheelSceneGenerator gen(sp);
      wheel_scene::SequenceSpec spec;
      spec.frames = o.frames;
      spec.max_sinkage_mm = l.max_mm;
      spec.start_angle_rad = 0.37 * idx;
      const auto frames = wheel_scene::make_sequence(gen, spec);
      ++idx;

      sk::WheelGeometry g = algo.geometry;
      sk::SinkageParams p = algo.params;
      if (!algo.from_file) {  // the scene's exact geometry and scale
        g = wheel_scene::sinkage_geometry(sp.wheel);
        p = wheel_scene::sinkage_params(sp.wheel, p);
      }
      sk::SinkageEstimator est(g, p, sp.size);
      Condition& c = condition(rows, l.name, li.name);
      sk::SinkageResult r;
      for (const auto& f : frames) {
        est.process(f.bgr, f.truth.encoder_angle_rad, r);
        c.samples.push_back({f.truth.sinkage_mm, r.valid ? r.sinkage_mm : 0.0, r.valid});
      }
      if (!o.write_dir.empty()) {
        std::string load_dir = l.name;
        for (char& ch : load_dir)
          if (ch == ' ' || ch == '.') ch = '_';
        const fs::path dir = fs::path(o.write_dir) / (load_dir + "_" + li.dir);
        try {
          wheel_scene::write_sequence(dir, frames,
                                      {std::string("load: ") + l.name, std::string("illumination: ") + li.name});
        } catch (const std::runtime_error& e) {
          throw InputError(e.what());
        }
      }
    }
  }
}
#endif

void run_eval(const EvalOptions& given) {
  // Bare `regolith eval sinkage`: the synthetic conditions, as with --synthetic.
  EvalOptions o = given;
  const bool no_input = !o.synthetic && o.sequences.empty() && o.logs.empty();
#ifdef REGOLITH_HAVE_WHEEL_SCENE
  o.synthetic = o.synthetic || no_input;
#else
  if (no_input) throw InputError("eval sinkage: give --sequence DIR_OR_CSV or --log BENCH_LOG.csv");
#endif
  const Algorithm algo = load_algorithm(o);
  std::vector<Condition> rows;
  if (o.synthetic) {
#ifdef REGOLITH_HAVE_WHEEL_SCENE
    eval_synthetic(o, algo, rows);
#else
    throw InputError("eval sinkage --synthetic needs mocks/wheel_scene in this build");
#endif
  }
  for (const auto& s : o.sequences) eval_sequence(s, algo, rows);
  for (const auto& l : o.logs) eval_log(l, rows);

  std::vector<sk::ConditionSummary> table;
  std::size_t no_truth = 0;
  for (const auto& c : rows) {
    table.push_back({c.load, c.illumination, sk::evaluate(c.samples)});
    no_truth += c.without_truth;
  }
  std::cout << "# sinkage error vs ground truth (thesis Table 4.1 analogue): mean / max absolute error over the valid "
               "frames, in mm, in % of the mean ground truth (%GT) and of the maximum ground truth (%max)\n";
  if (no_input) std::cout << "# no --sequence or --log given: the synthetic conditions (--synthetic)\n";
  if (o.synthetic) {
    std::cout << "# synthetic: " << o.frames << " frames per condition, misalignment " << o.misalignment_deg
              << " deg, seed " << o.seed << (algo.from_file ? ", geometry from " + o.params : ", exact scene geometry")
              << "\n";
  }
  if (no_truth > 0) std::cout << "# " << no_truth << " log rows without a transducer reading were left out\n";
  std::cout << sk::format_table(table);
}

}  // namespace

void add_sinkage_commands(CLI::App& app) {
  CLI::App* cal = group(app, "calibrate", "calibration tools");
  auto co = std::make_shared<CalibrateOptions>();
  CLI::App* c = cal->add_subcommand("sinkage",
                                    "wheel-leg geometry (hub centre, leg length / width, angle offset) from "
                                    "a frame of the un-sunk wheel; prints the YAML geometry block");
  c->add_option("frame", co->frame, "image of the un-sunk wheel (colour)")->required();
  c->add_option("--angle", co->angle_rad, "rad, encoder angle when the frame was captured")->required();
  c->add_option("--leg-count", co->leg_count, "legs on the wheel")->check(CLI::Range(2, 16))->capture_default_str();
  c->add_option("--spacing-rad", co->spacing_rad, "rad between legs (default 2 pi / leg count)");
  c->add_option("--direction", co->direction, "+1 / -1: sign of the encoder angle in the image")
      ->check(CLI::IsMember({-1, 1}))
      ->capture_default_str();
  c->add_option("--segmentation", co->segmentation, "hsv|adaptive|auto")
      ->check(CLI::IsMember({"hsv", "adaptive", "auto"}))
      ->capture_default_str();
  c->add_option("--hue-min", co->hue_min, "deg, leg colour band")->capture_default_str();
  c->add_option("--hue-max", co->hue_max, "deg")->capture_default_str();
  c->add_option("--sat-min", co->sat_min, "[0, 1]")->capture_default_str();
  c->add_option("--val-min", co->val_min, "[0, 1]")->capture_default_str();
  c->add_option("--min-leg-area", co->min_leg_area, "px^2, smaller blobs are ignored")->capture_default_str();
  c->add_option("--overlay", co->overlay, "write the calibrated template drawn on the frame to this PNG");
  c->callback([co] { run_calibrate(*co); });

  CLI::App* ev = group(app, "eval", "evaluate algorithms against ground truth");
  auto eo = std::make_shared<EvalOptions>();
  CLI::App* e = ev->add_subcommand("sinkage",
                                   "sinkage error per load x illumination (thesis Table 4.1 analogue) "
                                   "from recorded / synthetic sequences or bench-rig logs");
  e->add_option("--sequence", eo->sequences,
                "sequence folder (with sequence.csv) or CSV 'frame,encoder_angle_rad,truth_mm'; '# load: X' and "
                "'# illumination: Y' comment lines label the condition (default: the folder name)");
  e->add_option("--log", eo->logs, "bench-rig log written by the wheel_sinkage component (log_csv)");
  e->add_flag("--synthetic", eo->synthetic,
              "generate the four conditions (3.5 / 1.0 kg x 300-400 / 10-15 lux); what runs when no --sequence or "
              "--log is given");
  e->add_option("--params", eo->params, "YAML with the geometry block and estimator keys, or a deployment");
  e->add_option("--component", eo->component, "with a deployment in --params: the component name");
  e->add_option("--frames", eo->frames, "synthetic: frames per condition")
      ->check(CLI::Range(4, 100000))
      ->capture_default_str();
  e->add_option("--misalignment-deg", eo->misalignment_deg, "synthetic: true legs minus encoder prediction")
      ->check(CLI::Range(-30.0, 30.0))
      ->capture_default_str();
  e->add_option("--seed", eo->seed, "synthetic: scene seed")->capture_default_str();
  e->add_option("--write", eo->write_dir, "synthetic: also write the sequences (PNG + sequence.csv) under this folder");
  e->callback([eo] { run_eval(*eo); });
}

[[maybe_unused]] const bool registered_sinkage = add_command(add_sinkage_commands);

}  // namespace regolith::cli
