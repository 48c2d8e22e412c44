// libFuzzer target: the recorded-drive reader behind `regolith map DRIVE_DIR` (input.json: camera,
// mount, sun, wheel; frames.csv: frame, file, time, wheel odometry). An input is the two files
// separated by the first NUL byte (input.json before it, frames.csv after; no NUL: no frames.csv).
// Any input either reads as a drive or throws an InputError naming the file, line and field; the
// frame images themselves are not read here (the image target covers decoding).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <string>
#include <system_error>

#include <unistd.h>

#include "regolith/mapping/drive_io.hpp"

namespace {

void write_file(const std::filesystem::path& p, const std::uint8_t* data, std::size_t size) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace fs = std::filesystem;
  static const fs::path dir = fs::temp_directory_path() / ("regolith_fuzz_drive_" + std::to_string(::getpid()));
  std::error_code ec;
  fs::create_directories(dir, ec);
  const auto* nul = static_cast<const std::uint8_t*>(std::memchr(data, 0, size));
  const std::size_t json_size = nul != nullptr ? static_cast<std::size_t>(nul - data) : size;
  write_file(dir / "input.json", data, json_size);
  if (nul != nullptr)
    write_file(dir / "frames.csv", nul + 1, size - json_size - 1);
  else
    fs::remove(dir / "frames.csv", ec);
  try {
    const regolith::mapping::RecordedDrive d = regolith::mapping::read_drive(dir);
    (void)d;
  } catch (const std::exception&) {
    // InputError naming the file and field: expected
  }
  fs::remove_all(dir, ec);  // nothing left in the temp dir when the run ends
  return 0;
}
