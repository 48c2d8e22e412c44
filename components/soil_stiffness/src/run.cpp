#include "regolith/soil_stiffness/run.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <optional>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>

#include "regolith/common/plot.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/json_text.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/soil_stiffness/mission_table.hpp"

namespace regolith::soil {

cv::Mat read_soil_frame(const std::filesystem::path& image_path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(image_path, ec)) throw InputError(image_path.string() + ": no such image file");
  std::string why;
  cv::Mat image = regolith::read_image_8bit(image_path.string(), cv::IMREAD_GRAYSCALE, &why);
  if (image.empty()) throw InputError(image_path.string() + ": cannot decode the image: " + why);
  return image;
}

namespace {

using plot::PlotSeries;
using plot::PlotSpec;
using plot::render_plot;
using plot::write_png;

nlohmann::json num(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

const cv::Scalar kColours[] = {{200, 60, 20},  {30, 30, 220}, {40, 160, 40},
                               {160, 40, 160}, {0, 140, 220}, {120, 120, 0}};

// The track DTM on metric axes (range behind the camera, lateral), heights in mm.
cv::Mat render_dtm(const SoilStiffnessEstimator& est) {
  const cv::Mat& dtm = est.dtm_m();
  plot::MapStyle style;
  style.title = "SfS DTM of the track region (mm)";
  style.unit_label = "mm";
  style.scale = 1000.0;
  style.palette = plot::Palette::jet;
  style.image_height_px = 480;
  if (dtm.rows > 1 && dtm.cols > 1) {
    const auto edge = [](double first, double second) { return first - 0.5 * (second - first); };
    plot::MapAxes a;
    a.top = edge(est.row_range_m(0), est.row_range_m(1));
    a.bottom = edge(est.row_range_m(dtm.rows - 1), est.row_range_m(dtm.rows - 2));
    a.left = edge(est.col_lateral_m(0), est.col_lateral_m(1));
    a.right = edge(est.col_lateral_m(dtm.cols - 1), est.col_lateral_m(dtm.cols - 2));
    a.y_label = "range behind the camera (m)";
    a.x_label = "lateral, + left (m)";
    style.axes = a;
  }
  return plot::render_map(dtm, style);
}

}  // namespace

std::string estimate_to_json(const SoilEstimate& e, const RoverConfig& rover, int indent) {
  nlohmann::json j;
  j["ok"] = e.ok;
  j["reason"] = e.reason;
  j["rejected_tracks"] = e.rejected;
  j["rover"] = {{"mass_kg", rover.mass_kg},
                {"wheel_count", rover.wheel_count},
                {"gravity_mps2", rover.gravity_mps2},
                {"wheel_width_m", rover.wheel_width_m},
                {"wheel_diameter_m", rover.wheel_diameter_m},
                {"wheel_load_n", rover.wheel_load_n()}};
  j["mean_sinkage_m"] = num(e.mean_sinkage_m);
  j["samples_used"] = e.samples_used;
  j["fixed_n"] = {{"n", e.n_fixed},
                  {"k", num(e.k_fixed)},
                  {"k_std", num(e.k_fixed_std)},
                  {"k_p25", num(e.k_spread_p25)},
                  {"k_p75", num(e.k_spread_p75)},
                  {"k_unit", "N/m^(n+2)"}};
  j["joint"] = {{"ok", e.joint_ok},    {"reason", e.joint_reason},    {"k", num(e.k_joint)},
                {"n", num(e.n_joint)}, {"k_std", num(e.k_joint_std)}, {"n_std", num(e.n_joint_std)}};
  j["estimate"] = {{"k", num(e.k)},
                   {"n", num(e.n)},
                   {"k_std", num(e.k_std)},
                   {"n_std", num(e.n_std)},
                   {"n_data_std", num(e.n_data_std)},
                   {"k_unit", "N/m^(n+2)"}};
  j["soil_class"] = to_string(e.soil_class);
  j["class_pressure_pa"] = num(e.class_pressure_pa);
  j["tracks"] = nlohmann::json::array();
  for (const auto& t : e.tracks) {
    nlohmann::json tj;
    tj["lateral_m"] = t.lateral_m;
    tj["load_n"] = t.load_n;
    tj["mean_sinkage_m"] = t.mean_sinkage_m;
    tj["std_sinkage_m"] = t.std_sinkage_m;
    tj["samples"] = t.samples;
    tj["k_fixed"] = num(t.k_fixed);
    nlohmann::json prof = nlohmann::json::array();
    for (std::size_t i = 0; i < t.range_m.size(); ++i) prof.push_back({t.range_m[i], num(t.sinkage_m[i])});
    tj["profile_range_sinkage_m"] = std::move(prof);
    j["tracks"].push_back(std::move(tj));
  }
  return regolith::json_text(j, indent);
}

cv::Mat render_track_overlay(const cv::Mat& image, const CameraModel& camera, const RoverConfig& rover,
                             const TrackAnalysisParams& params, const SoilEstimate& e) {
  cv::Mat out;
  if (image.channels() == 1)
    cv::cvtColor(image, out, cv::COLOR_GRAY2BGR);
  else
    image.copyTo(out);
  const direct_depth::DirectDepth geometry(camera);
  // shadowed pixels of the ground region (darker than shadow_fraction of its median), tinted blue
  cv::Mat grey;
  if (image.channels() == 1)
    grey = image;
  else
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  std::vector<unsigned char> region;
  for (int r = 0; r < grey.rows; r += 2)
    for (int c = 0; c < grey.cols; c += 2) {
      const auto g = geometry.ground(c, r);
      if (g.valid && g.range_m >= params.range_min_m && g.range_m <= params.range_max_m &&
          g.lateral_m >= params.lateral_min_m && g.lateral_m <= params.lateral_max_m)
        region.push_back(grey.at<unsigned char>(r, c));
    }
  if (!region.empty()) {
    std::nth_element(region.begin(), region.begin() + static_cast<std::ptrdiff_t>(region.size() / 2), region.end());
    const double dark = params.shadow_fraction * region[region.size() / 2];
    for (int r = 0; r < out.rows; ++r)
      for (int c = 0; c < out.cols; ++c)
        if (grey.at<unsigned char>(r, c) < dark) {
          auto& px = out.at<cv::Vec3b>(r, c);
          px = cv::Vec3b(static_cast<unsigned char>(std::min(255, px[0] + 140)), px[1], px[2]);
        }
  }
  // per track: the measured floor edges (at the floor's depth) and wall tops; cross-sections
  const double hb = 0.5 * rover.wheel_width_m, tan_w = std::tan(params.wall_slope_rad);
  for (std::size_t t = 0; t < e.tracks.size(); ++t) {
    const TrackProfile& tr = e.tracks[t];
    const cv::Scalar colour = kColours[t % 6];
    std::vector<cv::Point> floor_l, floor_r, top_l, top_r;
    auto px = [&](double range, double lateral, double z) -> std::optional<cv::Point> {
      const auto p = geometry.project(range, lateral, z);
      if (!p) return std::nullopt;
      return cv::Point(static_cast<int>(std::lround(p->x)), static_cast<int>(std::lround(p->y)));
    };
    for (std::size_t i = 0; i < tr.range_m.size(); ++i) {
      const double z = tr.sinkage_m[i];
      if (!std::isfinite(z)) continue;
      const double x = tr.range_m[i], y = tr.lateral_m;
      if (auto p = px(x, y + hb, -z)) floor_l.push_back(*p);
      if (auto p = px(x, y - hb, -z)) floor_r.push_back(*p);
      if (auto p = px(x, y + hb + z / tan_w, 0.0)) top_l.push_back(*p);
      if (auto p = px(x, y - hb - z / tan_w, 0.0)) top_r.push_back(*p);
    }
    for (const auto* line : {&floor_l, &floor_r}) cv::polylines(out, *line, false, colour, 2, cv::LINE_AA);
    for (const auto* line : {&top_l, &top_r}) cv::polylines(out, *line, false, cv::Scalar(0, 220, 255), 1, cv::LINE_AA);
    // a cross-section line every ~0.25 m, labelled with its depth
    double next = -1e9;
    for (std::size_t i = 0; i < tr.range_m.size(); ++i) {
      const double z = tr.sinkage_m[i];
      if (!std::isfinite(z) || std::abs(tr.range_m[i] - next) < 0.25) continue;
      next = tr.range_m[i];
      const double reach = hb + z / tan_w + 0.03;
      const auto a = px(tr.range_m[i], tr.lateral_m + reach, 0.0), b = px(tr.range_m[i], tr.lateral_m - reach, 0.0);
      if (!a || !b) continue;
      cv::line(out, *a, *b, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
      char lab[32];
      std::snprintf(lab, sizeof lab, "%.1f mm", z * 1e3);
      // right of the line's end, moved left as far as it takes to stay in the picture
      int base = 0;
      const cv::Size ts = cv::getTextSize(lab, cv::FONT_HERSHEY_SIMPLEX, 0.4, 1, &base);
      const cv::Point at(std::clamp(b->x + 4, 2, std::max(2, out.cols - ts.width - 2)), b->y - 3);
      cv::putText(out, lab, at, cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    }
  }
  cv::rectangle(out, cv::Rect(0, 0, out.cols, 34), cv::Scalar(0, 0, 0), cv::FILLED);
  char head[200];
  std::snprintf(head, sizeof head, "floor edges (colour), wall tops (yellow), shadow (blue): k %.2g n %.2f", e.k, e.n);
  cv::putText(out, head, cv::Point(6, 22), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return out;
}

SoilAnalysisFiles run_soil_analysis(const cv::Mat& image, const CameraModel& camera, const RoverConfig& rover,
                                    const TrackAnalysisParams& params, const SunDirection& sun,
                                    const std::filesystem::path& out_dir) {
  SoilStiffnessEstimator est(camera, rover, params);
  SoilAnalysisFiles f;
  est.estimate(image, sun, f.estimate);
  const SoilEstimate& e = f.estimate;
  make_output_dir(out_dir.string(), "the soil analysis' output directory");

  if (e.ok) {
    f.dtm_png = out_dir / "track_dtm.png";
    write_png(f.dtm_png, render_dtm(est));
  }
  // sinkage profiles
  {
    std::vector<PlotSeries> s;
    for (std::size_t t = 0; t < e.tracks.size(); ++t) {
      PlotSeries p;
      char lab[96];
      std::snprintf(lab, sizeof lab, "track y=%.2f m, W=%.0f N", e.tracks[t].lateral_m, e.tracks[t].load_n);
      p.label = lab;
      p.x = e.tracks[t].range_m;
      for (double z : e.tracks[t].sinkage_m) p.y.push_back(z * 1000.0);
      p.colour = kColours[t % 6];
      s.push_back(std::move(p));
    }
    PlotSpec spec{e.ok ? "Sinkage profiles" : "Sinkage profiles: " + e.reason, "range behind the camera [m]",
                  "sinkage [mm]"};
    f.profiles_png = out_dir / "sinkage_profiles.png";
    write_png(f.profiles_png, render_plot(spec, s));
  }
  // p-z curves: this estimate + mission table (traditional values)
  {
    std::vector<PlotSeries> s;
    const double zmax = std::max(0.05, e.ok ? 2.0 * e.mean_sinkage_m : 0.0);
    auto add = [&](const std::string& label, double k, double n, cv::Scalar c, bool dashed) {
      PlotSeries p;
      p.label = label;
      for (const auto& [z, pr] : pz_curve(k, n, zmax, 64)) {
        p.x.push_back(z * 1000.0);
        p.y.push_back(pr / 1000.0);
      }
      p.colour = c;
      p.dashed = dashed;
      s.push_back(std::move(p));
    };
    if (e.ok) {
      char lab[96];
      std::snprintf(lab, sizeof lab, "image: k %.2g, n %.2f+-%.2f", e.k, e.n, e.n_std);
      add(lab, e.k, e.n, {0, 0, 200}, false);
      // +-1 sigma band: ln p = ln k + n ln z, narrowest at the measured mean depth
      const double rel_k = e.k_fixed > 0 ? e.k_fixed_std / e.k_fixed : 0.0;
      for (int side : {-1, 1}) {
        PlotSeries p;
        p.label = side < 0 ? "image: +-1 sigma" : "";
        for (const auto& [z, pr] : pz_curve(e.k, e.n, zmax, 64)) {
          const double rel = std::hypot(rel_k, std::log(std::max(z, 1e-4) / e.mean_sinkage_m) * e.n_std);
          p.x.push_back(z * 1000.0);
          p.y.push_back(pr * std::exp(side * rel) / 1000.0);
        }
        p.colour = {120, 120, 230};
        p.dashed = true;
        s.push_back(std::move(p));
      }
      add("image, n fixed " + std::to_string(e.n_fixed).substr(0, 4), e.k_fixed, e.n_fixed, {0, 0, 0}, false);
    }
    // The three missions share the Sourcebook soil and differ only in wheel width (k = k_c / b +
    // k_phi moves by 0.4 %): one curve, not three on top of each other.
    const std::vector<MissionEntry> missions = mission_table();
    double k_sum = 0.0;
    for (const auto& m : missions) k_sum += m.k_traditional();
    add("Lunar Sourcebook soil (Luna 17, Apollo 15, Chang'E-3)", k_sum / static_cast<double>(missions.size()),
        missions.front().n, kColours[2], true);
    PlotSpec spec{"Pressure-sinkage p = k z^n", "sinkage z [mm]", "pressure p [kPa]"};
    f.pz_png = out_dir / "pz_curves.png";
    write_png(f.pz_png, render_plot(spec, s));
  }
  if (e.ok) {
    f.overlay_png = out_dir / "tracks_overlay.png";
    write_png(f.overlay_png, render_track_overlay(image, camera, rover, params, e));
  }
  f.json = out_dir / "result.json";
  write_file(f.json.string(), estimate_to_json(e, rover) + "\n", "the result");
  return f;
}

}  // namespace regolith::soil
