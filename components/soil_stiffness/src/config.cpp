#include "regolith/soil_stiffness/config.hpp"

#include <cmath>
#include <stdexcept>
#include <vector>

#include "regolith/common/camera.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/rover.hpp"

namespace regolith::soil {
namespace {

constexpr double kPi = 3.14159265358979323846;

constexpr const char* kCameraMoved = "the camera is described once, in rover.cameras.<camera> {camera_info, mount}";

RoverConfig rover_config(Params& p, const RoverDescription& d) {
  if (!(d.mass_kg > 0.0) || d.wheels.empty())
    p.fail({},
           "soil stiffness needs the rover's mass and wheels: rover.mass_kg and rover.wheels "
           "[{name, x_m, y_m, radius_m, width_m}] (the load per wheel is M g / wheel count)");
  RoverConfig r;
  r.mass_kg = d.mass_kg;
  if (d.gravity_mps2 > 0.0) r.gravity_mps2 = d.gravity_mps2;
  r.wheel_count = static_cast<int>(d.wheels.size());
  r.wheel_width_m = d.wheels.front().width_m;
  r.wheel_diameter_m = 2.0 * d.wheels.front().radius_m;
  for (const auto& w : d.wheels)
    if (w.width_m != r.wheel_width_m || 2.0 * w.radius_m != r.wheel_diameter_m)
      p.fail({}, "soil stiffness assumes identical wheels: rover.wheels '" + w.name + "' differs from '" +
                     d.wheels.front().name + "'");
  try {
    r.validate();
  } catch (const FieldError& e) {
    p.fail({}, "rover." + std::string(e.what()));
  }
  return r;
}

// The rectified region behind the rover that holds the tracks (`region:`).
void read_region(Params& p, TrackAnalysisParams& a) {
  Params r = p.child("region");
  a.range_min_m =
      r.get<double>("range_min_m", a.range_min_m,
                    {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "near edge of the track region"});
  a.range_max_m =
      r.get<double>("range_max_m", a.range_max_m, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "far edge"});
  a.lateral_min_m = r.get<double>("lateral_min_m", a.lateral_min_m, {.unit = "m", .doc = "right edge (left +)"});
  a.lateral_max_m = r.get<double>("lateral_max_m", a.lateral_max_m, {.unit = "m", .doc = "left edge"});
  a.grid_res_m =
      r.get<double>("grid_res_m", a.grid_res_m,
                    {.unit = "m", .min = 0.0, .max = 0.2, .min_exclusive = true, .doc = "rectified cell size"});
  r.finish();
}

// The ruts: configured centres and loads, or automatic detection (`tracks:`).
void read_tracks(Params& p, TrackAnalysisParams& a) {
  Params t = p.child("tracks");
  const auto lat = t.get<std::vector<double>>(
      "lateral_m", {}, {.unit = "m", .doc = "configured rut centres (empty = automatic detection)"});
  const auto load = t.get<std::vector<double>>(
      "load_n", {}, {.unit = "N", .min = 0.0, .doc = "wheel load per configured rut (empty or 0 = M g / wheel_count)"});
  if (lat.size() > kMaxTracks)
    t.fail("lateral_m", "at most " + std::to_string(kMaxTracks) + " ruts (got " + std::to_string(lat.size()) + ")");
  if (!load.empty() && load.size() != lat.size())
    t.fail("load_n", "needs one load per lateral_m entry (" + std::to_string(lat.size()) + "), got " +
                         std::to_string(load.size()));
  a.tracks.clear();
  for (std::size_t i = 0; i < lat.size(); ++i) a.tracks.push_back({lat[i], load.empty() ? 0.0 : load[i]});
  a.track_search_m = t.get<double>("search_m", a.track_search_m,
                                   {.unit = "m", .min = 0.0, .doc = "search +- around a configured rut"});
  a.max_tracks =
      t.get<int>("max_tracks", a.max_tracks,
                 {.min = 1, .max = static_cast<int>(kMaxTracks), .doc = "automatic detection keeps at most this many"});
  a.min_sinkage_m =
      t.get<double>("min_sinkage_m", a.min_sinkage_m, {.unit = "m", .min = 0.0, .doc = "minimum mean rut depth"});
  a.detection_snr =
      t.get<double>("detection_snr", a.detection_snr, {.min = 0.0, .doc = "mean sinkage / standard error needed"});
  t.finish();
}

// How a rut's depth profile is measured (`profile:`): template, photoclinometry or the DTM, and shadows.
void read_profile(Params& p, TrackAnalysisParams& a) {
  Params q = p.child("profile");
  a.floor_fraction = q.get<double>(
      "floor_fraction", a.floor_fraction,
      {.min = 0.0, .max = 1.0, .min_exclusive = true, .doc = "central part of the rut used as its floor [b]"});
  a.shoulder_gap =
      q.get<double>("shoulder_gap", a.shoulder_gap, {.min = 0.0, .doc = "gap rut edge -> shoulder window [b]"});
  a.shoulder_width = q.get<double>("shoulder_width", a.shoulder_width,
                                   {.min = 0.0, .max = 5.0, .min_exclusive = true, .doc = "shoulder window width [b]"});
  a.profile_window_m = q.get<double>("window_m", a.profile_window_m,
                                     {.unit = "m", .min = 0.0, .doc = "along-track smoothing = bootstrap block"});
  a.presmooth_m = q.get<double>("presmooth_m", a.presmooth_m,
                                {.unit = "m", .min = 0.0, .doc = "along-track box filter before the inversion"});
  a.min_valid_fraction = q.get<double>("min_valid_fraction", a.min_valid_fraction,
                                       {.min = 0.0, .max = 1.0, .doc = "measurable rows needed"});
  const std::string src = q.get<std::string>("source", "template",
                                             {.choices = {"template", "photoclinometry", "sfs_dtm"},
                                              .doc = "rut depth: rendered cross-sections fitted to the image, 1-D "
                                                     "photoclinometry (+ shadow widths) or the SfS DTM"});
  a.profile_source = src == "sfs_dtm"           ? ProfileSource::kSfsDtm
                     : src == "photoclinometry" ? ProfileSource::kPhotoclinometry
                                                : ProfileSource::kTemplate;
  a.berm_offset =
      q.get<double>("berm_offset", a.berm_offset,
                    {.min = -1.0, .max = 5.0, .doc = "berm crest beyond the rut wall's top edge [b] (template)"});
  a.berm_half_width =
      q.get<double>("berm_half_width", a.berm_half_width,
                    {.min = 0.0, .max = 5.0, .min_exclusive = true, .doc = "berm half-width [b] (template)"});
  a.rut_template.max_sinkage_m = q.get<double>(
      "max_sinkage_m", a.rut_template.max_sinkage_m,
      {.unit = "m", .min = 0.0, .max = 0.5, .min_exclusive = true, .doc = "deepest rut the template fit considers"});
  a.rut_template.sinkage_step_m = q.get<double>(
      "sinkage_step_m", a.rut_template.sinkage_step_m,
      {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "template depth hypotheses spacing (parabola-refined)"});
  a.rut_template.centre_search_m =
      q.get<double>("centre_search_m", a.rut_template.centre_search_m,
                    {.unit = "m",
                     .min = 0.0,
                     .max = 0.3,
                     .doc = "+- lateral search of the template around the rut's nominal centre"});
  a.rut_template.huber_dn = q.get<double>(
      "huber_dn", a.rut_template.huber_dn,
      {.unit = "DN", .min = 0.0, .min_exclusive = true, .doc = "template residual beyond which the loss is linear"});
  const std::string m =
      q.get<std::string>("sfs_method", "pentland", {.choices = {"pentland", "tsai_shah"}, .doc = "DTM solver"});
  a.sfs_method = m == "tsai_shah" ? SfsMethod::kTsaiShah : SfsMethod::kPentland;
  a.sfs_iterations =
      q.get<int>("sfs_iterations", a.sfs_iterations, {.min = 1, .max = 100000, .doc = "Tsai-Shah iterations"});
  a.min_lateral_sun = q.get<double>("min_lateral_sun", a.min_lateral_sun,
                                    {.min = 0.0, .max = 0.999, .doc = "|cos(el) sin(az)| needed"});
  a.use_shadows = q.get<bool>("use_shadows", a.use_shadows,
                              {.doc = "rows with a measurable cast shadow in the rut take its depth"});
  a.shadow_fraction = q.get<double>(
      "shadow_fraction", a.shadow_fraction,
      {.min = 0.0, .max = 1.0, .min_exclusive = true, .doc = "shadow = darker than this x flat-ground brightness"});
  a.berm_ratio =
      q.get<double>("berm_ratio", a.berm_ratio,
                    {.min = 0.0, .max = 2.0, .doc = "berm crest height / sinkage (the crest casts the shadow)"});
  a.wall_slope_rad = q.get<double>("wall_slope_rad", a.wall_slope_rad,
                                   {.unit = "rad",
                                    .min = 0.0,
                                    .max = 1.57,
                                    .min_exclusive = true,
                                    .doc = "rut wall slope: shadows used only for a lower sun"});
  q.finish();
}

// The pressure-sinkage fit (`fit:`).
void read_fit(Params& p, TrackAnalysisParams& a) {
  Params f = p.child("fit");
  a.n_fixed = f.get<double>("n_fixed", a.n_fixed, {.min = 0.0, .doc = "sinkage exponent of the fixed-n fit"});
  const std::string model =
      f.get<std::string>("model", "bekker", {.choices = {"bekker", "beta"}, .doc = "rigid-wheel closed form"});
  a.model = model == "beta" ? SinkageModel::kBeta : SinkageModel::kBekker;
  a.bootstrap_samples =
      f.get<int>("bootstrap_samples", a.bootstrap_samples, {.min = 0, .max = 100000, .doc = "0 = no uncertainty"});
  a.seed = static_cast<std::uint32_t>(
      f.get<std::int64_t>("seed", a.seed, {.min = 0, .max = 4294967295.0, .doc = "bootstrap seed"}));
  a.min_load_ratio = f.get<double>("min_load_ratio", a.min_load_ratio,
                                   {.min = 1.0, .min_exclusive = true, .doc = "distinct loads for the joint fit"});
  f.finish();
}

// The frame-quality limits (`quality:`).
void read_quality(Params& p, TrackAnalysisParams& a) {
  Params q = p.child("quality");
  a.max_saturated_fraction = q.get<double>("max_saturated_fraction", a.max_saturated_fraction,
                                           {.min = 0.0, .max = 1.0, .doc = "region cells >= 250 DN"});
  a.max_dark_fraction =
      q.get<double>("max_dark_fraction", a.max_dark_fraction, {.min = 0.0, .max = 1.0, .doc = "region cells <= 5 DN"});
  q.finish();
}

// The soil class thresholds (`soil_class:`).
void read_soil_class(Params& p, TrackAnalysisParams& a) {
  Params c = p.child("soil_class");
  a.class_z_ref_m =
      c.get<double>("z_ref_m", a.class_z_ref_m,
                    {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "sinkage of the class pressure"});
  a.loose_below_pa = c.get<double>("loose_below_pa", a.loose_below_pa,
                                   {.unit = "Pa", .min = 0.0, .min_exclusive = true, .doc = "p(z_ref) below: loose"});
  a.firm_above_pa = c.get<double>("firm_above_pa", a.firm_above_pa,
                                  {.unit = "Pa", .min = 0.0, .min_exclusive = true, .doc = "p(z_ref) above: firm"});
  c.finish();
}

}  // namespace

SoilConfig read_soil_config(Params& p, const RoverDescription& rover, const RoverCamera& camera, int width_px,
                            int height_px) {
  p.reject_moved("camera_model", kCameraMoved);
  p.reject_moved("mount", kCameraMoved);
  p.reject_moved("sun",
                 "the deployment has one sun: a top-level `sun: {azimuth_deg, elevation_deg}` block, "
                 "converted into the camera's ground frame with its mount");
  p.reject_moved("rover", "the rover is described once: rover.mass_kg, rover.gravity_mps2 and rover.wheels");
  SoilConfig cfg;
  cfg.rover = rover_config(p, rover);
  cfg.camera = common::camera_model_for_frames(camera, width_px, height_px, p, "camera");
  cfg.mount = {camera.mount.x_m, camera.mount.y_m, camera.mount.yaw_rad};
  if (!rover.sun) p.fail({}, "soil stiffness needs the sun: add a top-level `sun: {azimuth_deg, elevation_deg}` block");
  cfg.sun = common::ground_sun(*rover.sun, camera);
  const common::GroundSun& gs = cfg.sun;
  if (!(gs.elevation_rad > 0.02))
    p.fail({}, "the sun is " + std::to_string(gs.elevation_rad * 180 / kPi) +
                   " deg above the ground in the camera's frame: the tracks are not lit");
  TrackAnalysisParams& a = cfg.analysis;
  read_region(p, a);
  read_tracks(p, a);
  read_profile(p, a);
  read_fit(p, a);
  read_quality(p, a);
  read_soil_class(p, a);
  try {
    a.validate();
  } catch (const std::invalid_argument& e) {
    p.fail({}, std::string("invalid estimator parameters: ") + e.what());
  }
  return cfg;
}

SoilAnalysisFiles run_soil_file(const std::filesystem::path& image_path, const std::filesystem::path& rover_yaml,
                                const std::filesystem::path& out_dir) {
  const cv::Mat image = read_soil_frame(image_path);
  std::error_code ec;
  if (!std::filesystem::is_regular_file(rover_yaml, ec))
    throw ConfigError(rover_yaml.string() + ": no such configuration file");
  Params root = Params::load_file(rover_yaml.string());
  const std::string dir = rover_yaml.has_parent_path() ? rover_yaml.parent_path().string() : ".";
  const RoverDescription rover = read_rover_description(root, dir);
  // The camera of the soil section: its `camera` key names a rover.cameras entry.
  auto read = [&](Params& c) {
    const std::string cam = c.require<std::string>("camera", {.doc = "the rear camera (rover.cameras.<name>)"});
    const RoverCamera* rc = rover.camera(cam);
    if (rc == nullptr)
      c.fail("camera",
             "no rover.cameras." + cam +
                 " in this file: describe the camera once there "
                 "{camera_info: {width, height, k, d} or camera_info_url, mount: {x_m, y_m, z_m, pitch_rad, yaw_rad}}");
    return read_soil_config(c, rover, *rc, image.cols, image.rows);
  };
  SoilConfig cfg;
  if (root.has("components")) {
    Params comps = root.child("components");
    bool found = false;
    for (const auto& name : comps.keys()) {
      Params c = comps.child(name);
      if (!c.node()["type"] || c.node()["type"].Scalar() != "soil_stiffness") continue;
      cfg = read(c);
      found = true;
      break;
    }
    if (!found) comps.fail({}, "no component of type soil_stiffness in this deployment");
  } else {
    Params s = root.require_child("soil_stiffness");
    cfg = read(s);
    s.finish();
    root.finish();
  }
  try {
    return run_soil_analysis(image, cfg.camera, cfg.rover, cfg.analysis, cfg.sun, out_dir);
  } catch (const std::invalid_argument& e) {
    throw InputError(image_path.string() + ": " + e.what());
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());  // output file problems name the file
  }
}

}  // namespace regolith::soil
