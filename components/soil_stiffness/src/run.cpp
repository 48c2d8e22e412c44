#include "regolith/soil_stiffness/run.hpp"

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <vector>

#include <nlohmann/json.hpp>

#include "regolith/soil_stiffness/mission_table.hpp"
#include "regolith/soil_stiffness/plot.hpp"

namespace regolith::soil {
namespace {

nlohmann::json num(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

const cv::Scalar kColours[] = {{200, 60, 20}, {30, 30, 220}, {40, 160, 40}, {160, 40, 160},
                               {0, 140, 220}, {120, 120, 0}};

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
  j["joint"] = {{"ok", e.joint_ok}, {"reason", e.joint_reason}, {"k", num(e.k_joint)},
                {"n", num(e.n_joint)}, {"k_std", num(e.k_joint_std)}, {"n_std", num(e.n_joint_std)}};
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
    for (std::size_t i = 0; i < t.range_m.size(); ++i)
      prof.push_back({t.range_m[i], num(t.sinkage_m[i])});
    tj["profile_range_sinkage_m"] = std::move(prof);
    j["tracks"].push_back(std::move(tj));
  }
  return j.dump(indent);
}

SoilAnalysisFiles run_soil_analysis(const cv::Mat& image, const CameraModel& camera,
                                    const RoverConfig& rover, const TrackAnalysisParams& params,
                                    const SunDirection& sun,
                                    const std::filesystem::path& out_dir) {
  SoilStiffnessEstimator est(camera, rover, params);
  SoilAnalysisFiles f;
  est.estimate(image, sun, f.estimate);
  const SoilEstimate& e = f.estimate;
  std::error_code ec;
  std::filesystem::create_directories(out_dir, ec);
  if (ec) throw std::runtime_error(out_dir.string() + ": cannot create directory: " + ec.message());

  if (e.ok) {
    f.dtm_png = out_dir / "track_dtm.png";
    write_png(f.dtm_png, render_height_map(est.dtm_m(), "SfS DTM of the track region (rows: range far->near)",
                                           "mm", 1000.0));
  }
  // sinkage profiles
  {
    std::vector<PlotSeries> s;
    for (std::size_t t = 0; t < e.tracks.size(); ++t) {
      PlotSeries p;
      char lab[96];
      std::snprintf(lab, sizeof lab, "track y=%.2f m, W=%.0f N", e.tracks[t].lateral_m,
                    e.tracks[t].load_n);
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
      add("image, n fixed", e.k_fixed, e.n_fixed, {0, 0, 0}, false);
      if (e.joint_ok) add("image, joint k,n", e.k_joint, e.n_joint, {0, 0, 200}, false);
    }
    int ci = 1;
    for (const auto& m : mission_table())
      add(m.mission + " (Sourcebook)", m.k_traditional(), m.n, kColours[ci++ % 6], true);
    PlotSpec spec{"Pressure-sinkage p = k z^n", "sinkage z [mm]", "pressure p [kPa]"};
    f.pz_png = out_dir / "pz_curves.png";
    write_png(f.pz_png, render_plot(spec, s));
  }
  f.json = out_dir / "result.json";
  std::ofstream os(f.json);
  if (!os) throw std::runtime_error(f.json.string() + ": cannot open for writing");
  os << estimate_to_json(e, rover) << "\n";
  if (!os) throw std::runtime_error(f.json.string() + ": write failed");
  return f;
}

}  // namespace regolith::soil
