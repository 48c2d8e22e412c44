#pragma once
// Reading a whole text file from outside (deployments, scene descriptions, recorded drives)
// with a bound: a path naming a device, FIFO or directory (`--config /dev/zero`) or a file larger
// than any sane input is refused with its name instead of being read until memory runs out.
// Writing a whole output file (the tools' JSON and CSV results) so that a failure is an error
// naming the file, also one that shows only when the file is closed; making an output directory.
#include <cerrno>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>

#include <sys/stat.h>

#include "regolith/core/error.hpp"

namespace regolith {

/// Default bound of read_text_file (configuration and scene files are kilobytes).
inline constexpr std::uintmax_t kMaxTextFileBytes = 16u << 20;

/// The contents of the regular file `path`, at most `max_bytes`. Throws InputError naming the
/// file ("PATH: cannot open ...", "PATH: not a regular file (a device, FIFO or directory)",
/// "PATH: N bytes, more than the M a WHAT may have").
inline std::string read_text_file(const std::string& path, const char* what = "file",
                                  std::uintmax_t max_bytes = kMaxTextFileBytes) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0)
    throw InputError(path + ": cannot open " + what + " (" + std::strerror(errno) + ")");
  if (!S_ISREG(st.st_mode))
    throw InputError(path + ": not a regular file (a device, FIFO or directory), not a " + what);
  if (static_cast<std::uintmax_t>(st.st_size) > max_bytes)
    throw InputError(path + ": " + std::to_string(st.st_size) + " bytes, more than the " + std::to_string(max_bytes) +
                     " a " + what + " may have");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot open " + what);
  std::ostringstream ss;
  ss << in.rdbuf();
  std::string text = ss.str();
  if (text.size() > max_bytes)
    throw InputError(path + ": grew past " + std::to_string(max_bytes) + " bytes while read");
  return text;
}

/// Creates the directory `path` (and its parents) unless it is there. Throws InputError "PATH:
/// cannot create WHAT (reason)" when that fails or something other than a directory is in the way.
inline void make_output_dir(const std::string& path, const std::string& what = "the output directory") {
  std::error_code ec;
  std::filesystem::create_directories(path, ec);
  if (ec || !std::filesystem::is_directory(path, ec))
    throw InputError(path + ": cannot create " + what + " (" + (ec ? ec.message() : "not a directory") + ")");
}

/// Closes `out`, the stream writing `path`, and throws InputError "PATH: cannot write WHAT
/// (reason)" when a write into it or the close failed: a file's last buffer reaches the disk only
/// at the close, so a full disk or a lost mount often shows there and nowhere before. The reason is
/// the errno of the failure when the library left one.
inline void close_output(std::ofstream& out, const std::string& path, const char* what = "file") {
  const bool wrote = static_cast<bool>(out);
  if (wrote) errno = 0;
  out.close();
  if (!out || !wrote) {
    const int e = errno;
    throw InputError(path + ": cannot write " + what + (e != 0 ? std::string(" (") + std::strerror(e) + ")" : ""));
  }
}

/// Writes `data` to `path` (created or truncated) and closes it (close_output's error when the
/// open, the write or the close fails).
inline void write_file(const std::string& path, std::string_view data, const char* what = "file") {
  errno = 0;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (out) out.write(data.data(), static_cast<std::streamsize>(data.size()));
  close_output(out, path, what);
}

}  // namespace regolith
