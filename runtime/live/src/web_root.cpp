#include "regolith/live/web_root.hpp"

#include <filesystem>
#include <system_error>

namespace regolith::live {

std::string default_web_root() {
  // index.html, not just the directory: a stale empty install directory must not hide the page.
  for (const char* dir : {REGOLITH_LIVE_WEB_INSTALL_DIR, REGOLITH_LIVE_WEB_SOURCE_DIR}) {
    std::error_code ec;
    if (std::filesystem::is_regular_file(std::filesystem::path(dir) / "index.html", ec)) return dir;
  }
  return {};
}

}  // namespace regolith::live
