#pragma once
// Where the built-in live page (runtime/live/web: index.html, app.js, cdr.js, style.css) is found,
// for FoxgloveServerOptions::web_root. Target regolith::live.
#include <string>

namespace regolith::live {

/// The installed page (<prefix>/share/regolith/web) when it exists, else the source tree's
/// runtime/live/web baked in at build time (a build run from its tree), else "" (no page).
std::string default_web_root();

}  // namespace regolith::live
