#pragma once
// JSON text of a document that may hold strings from outside (file names, frame ids, notes that
// quote them): bytes that are not UTF-8 become U+FFFD instead of nlohmann::json throwing
// (type_error 316) and losing the file being written (`regolith assess` on "caf\xe9.jpg" wrote
// every PNG but no summary.json). Header-only; callers link nlohmann_json as they do.
#include <string>

#include <nlohmann/json.hpp>

namespace regolith {

/// j.dump(indent) with invalid UTF-8 replaced (indent < 0: one line).
inline std::string json_text(const nlohmann::json& j, int indent = -1) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

}  // namespace regolith
