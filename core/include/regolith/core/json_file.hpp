#pragma once
// Reading JSON descriptions from outside (a recorded drive's or track scene's input.json, truth
// files): one parser call and one set of field readers, so every reader words its errors the same
// way ("FILE: camera.fx: must be a number") and bounds what it accepts the same way (sizes in
// pixels checked before the cast to int). Header-only; callers link nlohmann_json as they do.
#include <cmath>
#include <optional>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "regolith/core/error.hpp"
#include "regolith/core/image_file.hpp"
#include "regolith/core/text_file.hpp"

namespace regolith {

/// The JSON document in `path` (read whole, bounded by read_text_file). InputError naming the file
/// when it cannot be read ("PATH: cannot open WHAT ...") or is not JSON ("PATH: not valid JSON: ...").
inline nlohmann::json read_json_file(const std::string& path, const char* what) {
  const std::string text = read_text_file(path, what);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(path + ": not valid JSON: " + e.what());
  }
}

/// The finite number at the dotted `field` ("camera.fx") of `j`, read from `file`; std::nullopt
/// when the field or an object on its way is absent. InputError "FILE: FIELD: must be a number" /
/// "must be finite" when it is there but unusable, "FILE: camera: must be an object" when a step
/// on the way is not an object.
inline std::optional<double> json_optional_number(const nlohmann::json& j, const std::string& file,
                                                  std::string_view field) {
  const nlohmann::json* at = &j;
  std::string_view::size_type from = 0;
  while (true) {
    const auto dot = field.find('.', from);
    const std::string key(field.substr(from, dot == std::string_view::npos ? std::string_view::npos : dot - from));
    if (!at->is_object()) {
      const std::string parent(from == 0 ? std::string_view("the document") : field.substr(0, from - 1));
      throw InputError(file + ": " + parent + ": must be an object (holding " + std::string(field) + ")");
    }
    const auto it = at->find(key);
    if (it == at->end()) return std::nullopt;
    at = &*it;
    if (dot == std::string_view::npos) break;
    from = dot + 1;
  }
  if (!at->is_number()) throw InputError(file + ": " + std::string(field) + ": must be a number");
  const double v = at->get<double>();
  if (!std::isfinite(v)) throw InputError(file + ": " + std::string(field) + ": must be finite");
  return v;
}

/// As json_optional_number, with an absent field an error ("FILE: FIELD: missing").
inline double json_number(const nlohmann::json& j, const std::string& file, std::string_view field) {
  if (const auto v = json_optional_number(j, file, field)) return *v;
  throw InputError(file + ": " + std::string(field) + ": missing");
}

/// An image side: a whole number of pixels in 1..kMaxImageSidePx, checked before the cast (a huge
/// value is an error, not undefined behaviour).
inline int json_pixels(const nlohmann::json& j, const std::string& file, std::string_view field) {
  const double v = json_number(j, file, field);
  if (!(v >= 1.0 && v <= kMaxImageSidePx) || v != std::floor(v))
    throw InputError(file + ": " + std::string(field) + ": must be a whole number of pixels, 1.." +
                     std::to_string(kMaxImageSidePx));
  return static_cast<int>(v);
}

}  // namespace regolith
