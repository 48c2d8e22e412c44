// Every component type and HAL backend compiled into this build registers here. Optional parts
// (hardware backends, perception components) are compiled in when their targets exist.
#include "cli.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"

#ifdef REGOLITH_HAVE_MOCKS
#include "regolith/mocks/backends.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_V4L2
#include "regolith/hal_v4l2/v4l2.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
#include "regolith/hal_libcamera/libcamera.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
#include "regolith/hal_socketcan/socketcan.hpp"
#endif
// Component wrappers: target regolith_<name>_component, header regolith/<name>/component.hpp,
// function regolith::<name>::register_component().
#ifdef REGOLITH_HAVE_SFS_COMPONENT
#include "regolith/sfs/component.hpp"
#endif
#ifdef REGOLITH_HAVE_TRAVERSABILITY_COMPONENT
#include "regolith/traversability/component.hpp"
#endif
#ifdef REGOLITH_HAVE_SINKAGE_COMPONENT
#include "regolith/sinkage/component.hpp"
#endif
#ifdef REGOLITH_HAVE_SOIL_STIFFNESS_COMPONENT
#include "regolith/soil_stiffness/component.hpp"
#endif
#ifdef REGOLITH_HAVE_SALIENCY_COMPONENT
#include "regolith/saliency/component.hpp"
#endif

namespace regolith::cli {

void register_everything() {
  static bool done = false;
  if (done) return;
  done = true;
  runtime::register_builtin_components();
  [[maybe_unused]] auto& backends = hal::BackendRegistry::instance();
#ifdef REGOLITH_HAVE_MOCKS
  mocks::register_mock_backends(backends);
#endif
#ifdef REGOLITH_HAVE_HAL_V4L2
  hal::v4l2::register_v4l2_backend(backends);
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
  hal::libcam::register_libcamera_backend(backends);
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
  hal::socketcan::register_socketcan_backend(backends);
#endif
#ifdef REGOLITH_HAVE_SFS_COMPONENT
  sfs::register_component();
#endif
#ifdef REGOLITH_HAVE_TRAVERSABILITY_COMPONENT
  traversability::register_component();
#endif
#ifdef REGOLITH_HAVE_SINKAGE_COMPONENT
  sinkage::register_component();
#endif
#ifdef REGOLITH_HAVE_SOIL_STIFFNESS_COMPONENT
  soil::register_component();
#endif
#ifdef REGOLITH_HAVE_SALIENCY_COMPONENT
  saliency::register_component();
#endif
}

}  // namespace regolith::cli
