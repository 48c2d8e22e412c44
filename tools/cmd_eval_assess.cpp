// `regolith eval assess SCENE --out DIR`: the rocks `regolith assess` reported on a rendered
// perspective scene (the development sets' sfs/persp_dev_<i> format: truth.json with each rock's
// bbox_px, visible_px, touches_border, occluded_fraction, width_m, height_above_ground_m), scored
// as the thesis reports rock sizes: each measurable rock (>= 30 visible px, not on the border,
// < 30 % occluded) takes the reported box of largest IoU above 0.2, and its width and height
// errors are |derived - truth| / truth. Also counted: reported boxes on no rock (IoU <= 0.2 with
// every rock of >= 10 visible px: texture, shadows). JSON on stdout.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/json_file.hpp"
#include "regolith/core/json_text.hpp"

namespace regolith::cli {
namespace {

namespace fs = std::filesystem;

struct EvalAssessArgs {
  std::string scene, out;
};

// A box [xmin, ymin, xmax, ymax] of `file` at `field`, as the scorer has always read them (the
// extent as width and height: xmax - xmin).
cv::Rect read_box(const nlohmann::json& j, const std::string& file, const std::string& field) {
  const auto it = j.find(field);
  if (it == j.end() || !it->is_array() || it->size() != 4)
    throw InputError(file + ": " + field + ": must be [xmin, ymin, xmax, ymax]");
  int v[4];
  for (std::size_t k = 0; k < 4; ++k) {
    const nlohmann::json& e = (*it)[k];
    if (!e.is_number() || !std::isfinite(e.get<double>()) || std::abs(e.get<double>()) > 1e6)
      throw InputError(file + ": " + field + "[" + std::to_string(k) + "]: must be a pixel coordinate");
    v[k] = static_cast<int>(std::lround(e.get<double>()));
  }
  return {v[0], v[1], v[2] - v[0], v[3] - v[1]};
}

double iou(const cv::Rect& a, const cv::Rect& b) {
  const double inter = (a & b).area(), uni = a.area() + b.area() - inter;
  return uni > 0 ? inter / uni : 0.0;
}

nlohmann::json median_pct(std::vector<double> v) {
  if (v.empty()) return nullptr;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return 100.0 * v[v.size() / 2];
}

nlohmann::json evaluate_assess(const fs::path& scene, const fs::path& out) {
  const std::string tname = (scene / "truth.json").string(), sname = (out / "summary.json").string();
  const nlohmann::json truth = read_json_file(tname, "the scene's truth (truth.json)");
  const nlohmann::json summary = read_json_file(sname, "assess's summary (summary.json)");
  if (!truth.is_object() || !truth.contains("rocks") || !truth["rocks"].is_array())
    throw InputError(tname + ": rocks: must be an array");
  if (!summary.is_object() || !summary.contains("rocks") || !summary["rocks"].is_array())
    throw InputError(sname + ": rocks: missing (not a camera-mode run of `regolith assess`)");
  struct Reported {
    cv::Rect box;
    double width_m, height_m;
    std::optional<double> height_sfs_m;
  };
  std::vector<Reported> reported;
  for (std::size_t k = 0; k < summary["rocks"].size(); ++k) {
    const nlohmann::json& r = summary["rocks"][k];
    const std::string at = sname + ": rocks[" + std::to_string(k) + "]";
    if (!r.is_object()) throw InputError(at + ": must be an object");
    const nlohmann::json sfs = r.value("height_sfs_m", nlohmann::json());
    reported.push_back({read_box(r, at, "box_px"), json_number(r, at, "width_m"), json_number(r, at, "height_m"),
                        sfs.is_number() ? std::optional<double>(sfs.get<double>()) : std::nullopt});
  }
  std::vector<cv::Rect> visible;  // rocks of >= 10 visible px, for the boxes on no rock
  std::vector<double> werr, herr, serr;
  nlohmann::json rows = nlohmann::json::array();
  int measurable = 0;
  for (std::size_t q = 0; q < truth["rocks"].size(); ++q) {
    const nlohmann::json& t = truth["rocks"][q];
    const std::string at = tname + ": rocks[" + std::to_string(q) + "]";
    if (!t.is_object()) throw InputError(at + ": must be an object");
    const double visible_px = json_number(t, at, "visible_px");
    if (!t.contains("touches_border") || !t["touches_border"].is_boolean())
      throw InputError(at + ": touches_border: must be true or false");
    const cv::Rect tbox = read_box(t, at, "bbox_px");
    if (visible_px >= 10) visible.push_back(tbox);
    if (visible_px < 30 || t["touches_border"].get<bool>() || json_number(t, at, "occluded_fraction") >= 0.3) continue;
    ++measurable;
    const double tw = json_number(t, at, "width_m"), th = json_number(t, at, "height_above_ground_m");
    double best = 0.2;
    const Reported* match = nullptr;
    for (const Reported& r : reported)
      if (const double v = iou(r.box, tbox); v > best) best = v, match = &r;
    nlohmann::json row = {{"rock", q}, {"width_m", tw}, {"height_m", th}, {"matched", match != nullptr}};
    if (match) {
      werr.push_back(std::abs(match->width_m / tw - 1));
      herr.push_back(std::abs(match->height_m / th - 1));
      row["iou"] = best;
      row["reported_width_m"] = match->width_m;
      row["reported_height_m"] = match->height_m;
      if (match->height_sfs_m) {
        serr.push_back(std::abs(*match->height_sfs_m / th - 1));
        row["reported_height_sfs_m"] = *match->height_sfs_m;
      }
    }
    rows.push_back(row);
  }
  int on_none = 0;
  for (const Reported& r : reported)
    on_none += std::none_of(visible.begin(), visible.end(), [&](const cv::Rect& t) { return iou(r.box, t) > 0.2; });
  return {{"scene", scene.string()},
          {"assess", out.string()},
          {"measurable_rocks", measurable},
          {"boxed", werr.size()},
          {"reported_boxes", reported.size()},
          {"boxes_on_no_rock", on_none},
          {"rocks_below_min_score", summary.value("rocks_below_min_score", 0)},
          {"median_width_error_pct", median_pct(werr)},
          {"median_height_error_pct", median_pct(herr)},
          {"median_height_sfs_error_pct", median_pct(serr)},
          {"rocks", rows}};
}

[[maybe_unused]] const bool registered = add_command([](CLI::App& app) {
  auto a = std::make_shared<EvalAssessArgs>();
  CLI::App* eval = group(app, "eval", "evaluate algorithms against ground truth");
  CLI::App* ea = eval->add_subcommand(
      "assess", "score the rocks of a `regolith assess` run on a rendered perspective scene against its truth (JSON)");
  ea->add_option("scene", a->scene, "scene directory with truth.json (the sfs/persp_dev_<i> format)")->required();
  ea->add_option("--out", a->out, "output directory of `regolith assess` on that scene's image")->required();
  ea->callback([a] { std::cout << regolith::json_text(evaluate_assess(a->scene, a->out), 1) << "\n"; });
});

}  // namespace
}  // namespace regolith::cli
