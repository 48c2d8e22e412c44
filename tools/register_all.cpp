// Every component type and HAL backend compiled into this build registers here. Optional parts
// (hardware backends, perception components) are compiled in when their targets exist.
#include "cli.hpp"
#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"

#ifdef REGOLITH_HAVE_MOCKS
#include "regolith/mocks/backends.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_V4L2
#include "regolith/hal_v4l2/v4l2_camera.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
#include "regolith/hal_libcamera/libcamera_camera.hpp"
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
#include "regolith/hal_socketcan/socketcan_encoders.hpp"
#endif
#ifdef REGOLITH_HAVE_COMPONENTS
#include "regolith/components/register.hpp"
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
  hal::register_v4l2_backend(backends);
#endif
#ifdef REGOLITH_HAVE_HAL_LIBCAMERA
  hal::register_libcamera_backend(backends);
#endif
#ifdef REGOLITH_HAVE_HAL_SOCKETCAN
  hal::register_socketcan_backend(backends);
#endif
#ifdef REGOLITH_HAVE_COMPONENTS
  components::register_all_components();
#endif
}

}  // namespace regolith::cli
