// regolith devices: the cameras (V4L2, libcamera) and CAN interfaces this machine has, with their
// formats, plus the backends compiled in, so a user can write the deployment YAML.
#include <iostream>

#include "cli.hpp"
#include "regolith/hal/registry.hpp"

#ifdef REGOLITH_HAVE_HAL_V4L2
#include "regolith/hal_v4l2/v4l2.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
#include "regolith/hal_libcamera/libcamera.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
#include "regolith/hal_socketcan/socketcan.hpp"
#endif

namespace regolith::cli {
namespace {

void list_devices(bool with_libcamera) {
#ifdef REGOLITH_HAVE_HAL_V4L2
  const auto v4l2 = hal::v4l2::list_v4l2_devices(true);
  std::cout << "V4L2 cameras (backend: v4l2):" << (v4l2.empty() ? " none\n" : "\n");
  for (const auto& d : v4l2) {
    if (!d.capture) continue;
    std::cout << "  " << d.path << "  card: \"" << d.card << "\"  bus_info: \"" << d.bus_info << "\"  driver: " << d.driver
              << "\n";
    for (const auto& f : d.formats) {
      std::cout << "    " << f.fourcc << (f.convertible ? "" : " (not convertible)") << "  " << f.description << ":";
      for (const auto& s : f.sizes) {
        std::cout << " " << s.width << "x" << s.height;
        if (!s.rates_hz.empty()) {
          std::cout << "@";
          for (std::size_t i = 0; i < s.rates_hz.size(); ++i) std::cout << (i ? "/" : "") << s.rates_hz[i];
        }
      }
      if (!f.size_range.empty()) std::cout << " " << f.size_range;
      std::cout << "\n";
    }
  }
#else
  std::cout << "V4L2 backend not built\n";
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
  if (with_libcamera) {
    const auto cams = hal::libcam::list_libcamera_cameras();
    std::cout << "libcamera cameras (backend: libcamera):" << (cams.empty() ? " none\n" : "\n");
    for (const auto& c : cams) {
      std::cout << "  id: \"" << c.id << "\"" << (c.model.empty() ? "" : "  model: " + c.model) << "\n";
      for (const auto& f : c.formats) {
        std::cout << "    " << f.pixel_format << ":";
        for (const auto& [w, h] : f.sizes) std::cout << " " << w << "x" << h;
        if (!f.size_range.empty()) std::cout << " (" << f.size_range << ")";
        std::cout << "\n";
      }
    }
  }
#else
  (void)with_libcamera;
  std::cout << "libcamera backend not built\n";
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
  const auto cans = hal::socketcan::list_can_interfaces();
  std::cout << "CAN interfaces (backend: socketcan):" << (cans.empty() ? " none\n" : "\n");
  for (const auto& c : cans) {
    std::cout << "  " << c.name << "  " << (c.up ? "up" : "down") << "  kind: " << c.kind
              << (c.virtual_can ? " (virtual)" : "") << "  mtu: " << c.mtu << (c.mtu >= 72 ? " (CAN FD)" : "") << "\n";
  }
#else
  std::cout << "SocketCAN backend not built\n";
#endif
  std::cout << "camera backends:";
  for (const auto& [name, doc] : hal::BackendRegistry::instance().cameras()) std::cout << " " << name;
  std::cout << "\nencoder backends:";
  for (const auto& [name, doc] : hal::BackendRegistry::instance().encoders()) std::cout << " " << name;
  std::cout << "\n";
}

const bool registered = add_command([](CLI::App& app) {
  auto no_libcamera = std::make_shared<bool>(false);
  CLI::App* cmd = app.add_subcommand("devices", "list cameras and CAN interfaces, with formats, to help write the YAML");
  cmd->add_flag("--no-libcamera", *no_libcamera, "skip libcamera (its camera manager takes a few seconds to start)");
  cmd->callback([no_libcamera] { list_devices(!*no_libcamera); });
});

}  // namespace
}  // namespace regolith::cli
