#include "regolith/soil_stiffness/mission_table.hpp"

#include <cmath>
#include <limits>
#include <stdexcept>

namespace regolith::soil {

double MissionEntry::predicted_sinkage_m(SinkageModel model) const {
  return sinkage_from_soil(k_traditional(), n, rover.wheel_load_n(), rover.wheel_width_m, rover.wheel_diameter_m,
                           model);
}

double MissionEntry::k_from_reported_sinkage(SinkageModel model) const {
  if (!(reported_sinkage_m > 0.0)) return std::numeric_limits<double>::quiet_NaN();
  return stiffness_from_sinkage(reported_sinkage_m, n, rover.wheel_load_n(), rover.wheel_width_m,
                                rover.wheel_diameter_m, model);
}

std::vector<MissionEntry> mission_table() {
  constexpr double kMoonG = 1.62;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::string sourcebook =
      "Carrier, Olhoeft & Mendell, Lunar Sourcebook (1991) ch. 9: n = 1, k_c = 1.4 kN/m^2, "
      "k_phi = 820 kN/m^3 (as quoted in spec 5.3; not re-read here)";
  std::vector<MissionEntry> t;

  MissionEntry luna;
  luna.mission = "Luna 17";
  luna.vehicle = "Lunokhod 1";
  luna.rover = {756.0, 8, kMoonG, 0.20, 0.51};
  luna.vehicle_source =
      "D. A. Kring, 'Lunar Mobility Review', LPI Lunar Exploration Initiative briefing (2006): "
      "756 kg, 8 rigid wheels, diameter ~51 cm, width ~20 cm";
  luna.vehicle_verified = true;
  luna.soil_source = sourcebook;
  luna.reported_sinkage_m = nan;
  luna.sinkage_source = "no sourced rut depth (PrOP penetrometer data not retrieved)";
  t.push_back(luna);

  MissionEntry lrv;
  lrv.mission = "Apollo 15";
  lrv.vehicle = "Lunar Roving Vehicle";
  lrv.rover = {700.0, 4, kMoonG, 0.23, 0.818};
  lrv.vehicle_source =
      "Smithsonian NASM catalogue / Britannica: 210 kg empty + 490 kg payload = 700 kg loaded, "
      "4 wheels (verified); wheel 81.8 cm x 23 cm (recollection, not verified)";
  lrv.vehicle_verified = false;
  lrv.soil_source = sourcebook;
  lrv.reported_sinkage_m = 0.0125;
  lrv.sinkage_source = "Costes et al., NASA TR R-401 (1972): LRV rut depth ~1.25 cm (recollection, not verified)";
  t.push_back(lrv);

  MissionEntry ce3;
  ce3.mission = "Chang'E-3";
  ce3.vehicle = "Yutu";
  ce3.rover = {140.0, 6, kMoonG, 0.15, 0.30};
  ce3.vehicle_source =
      "NSSDC / Wikipedia infobox: landing mass 140 kg, six wheels (verified); wheel 0.30 m x "
      "0.15 m from spec 5.3 (not verified)";
  ce3.vehicle_verified = false;
  ce3.soil_source = sourcebook;
  ce3.reported_sinkage_m = nan;
  ce3.sinkage_source = "thesis Fig. 4.16 profile values not recovered; use the image method";
  t.push_back(ce3);
  return t;
}

std::vector<std::pair<double, double>> pz_curve(double k, double n, double z_max_m, int count) {
  if (count < 2) throw std::invalid_argument("count: need at least 2 points");
  if (!(z_max_m > 0.0)) throw std::invalid_argument("z_max_m: must be > 0");
  std::vector<std::pair<double, double>> c;
  c.reserve(static_cast<std::size_t>(count));
  for (int i = 0; i < count; ++i) {
    const double z = z_max_m * i / (count - 1);
    c.emplace_back(z, bg_pressure(k, n, z));
  }
  return c;
}

}  // namespace regolith::soil
