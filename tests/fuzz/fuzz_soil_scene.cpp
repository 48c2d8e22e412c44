// libFuzzer target: the readers of a recorded or rendered scene's input.json, the one behind
// `regolith soil IMAGE --scene input.json` (camera intrinsics, height, pitch, sun, wheel geometry,
// tracks) and, when the build has it, the one behind `regolith assess IMAGE --scene input.json`
// (orthographic or perspective camera, sun, flat field). Any input either gives a validated setup
// or an InputError naming the file and field.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include <unistd.h>

#include "regolith/soil_stiffness/scene.hpp"
#ifdef REGOLITH_FUZZ_ASSESS_SCENE
#include "regolith/common/scene.hpp"
#endif

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::filesystem::path file =
      std::filesystem::temp_directory_path() / ("regolith_fuzz_scene_" + std::to_string(::getpid()) + ".json");
  {
    std::ofstream out(file, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  try {
    const regolith::soil::SoilSetup s = regolith::soil::read_soil_scene(file);
    (void)s;
  } catch (const std::exception&) {
    // InputError naming the field: expected
  }
#ifdef REGOLITH_FUZZ_ASSESS_SCENE
  try {
    const regolith::common::SceneDescription d = regolith::common::read_scene_description(file.string(), 640, 480);
    (void)d;
  } catch (const std::exception&) {
    // InputError naming the field: expected
  }
#endif
  std::error_code ec;
  std::filesystem::remove(file, ec);  // nothing left in the temp dir when the run ends
  return 0;
}
