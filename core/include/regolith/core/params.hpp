#pragma once
// Declarative, validated access to one YAML mapping. Every parameter is declared where it is read,
// with its type, unit, default and range; reading records the resolved value (for
// `regolith config check`) and `finish()` rejects keys nobody declared, with a did-you-mean.
// All problems throw ConfigError("file:line:col: path.to.field: problem").
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "regolith/core/error.hpp"

namespace regolith {

struct ParamSpec {
  std::string_view unit{};             ///< SI unit ("m", "rad", "Hz", "px", "" for none)
  std::optional<double> min{};         ///< inclusive lower bound (numbers, list elements, list sizes for min_size)
  std::optional<double> max{};         ///< inclusive upper bound
  bool min_exclusive = false;          ///< lower bound is exclusive (e.g. period > 0)
  std::vector<std::string> choices{};  ///< allowed values of a string parameter
  std::string_view doc{};              ///< one-line description
};

/// One parameter as resolved from a file: for `config check` and `config schema` output.
struct ResolvedParam {
  std::string path;   ///< e.g. components.sfs.iterations
  std::string type;   ///< bool, int, double, string, double[], string[]
  std::string value;  ///< YAML rendering of the value in use
  std::string unit;
  std::string range;  ///< e.g. "[0, 1]", "> 0", "one of skip|catch_up"
  std::string doc;
  bool defaulted = false;
};

class Params {
 public:
  /// Load and parse a YAML file; syntax errors become ConfigError naming file:line:col.
  static Params load_file(const std::string& path);
  /// Parse YAML text (e.g. an embedded default); `name` is used in messages in place of a file.
  static Params load_string(const std::string& text, const std::string& name);

  Params(YAML::Node node, std::string file, std::string path,
         std::shared_ptr<std::vector<ResolvedParam>> sink = nullptr);

  /// Optional parameter with a default.
  template <class T>
  T get(std::string_view key, const T& default_value, const ParamSpec& spec = {});
  /// Mandatory parameter: absent -> error.
  template <class T>
  T require(std::string_view key, const ParamSpec& spec = {});

  bool has(std::string_view key) const;
  /// Nested mapping (absent -> an empty mapping, so its defaults apply).
  Params child(std::string_view key);
  /// Mandatory nested mapping.
  Params require_child(std::string_view key);
  /// A sequence of mappings, e.g. rate_groups: [{name: ...}, ...].
  std::vector<Params> child_list(std::string_view key, bool required = false);
  /// Keys of a mapping whose keys are user-chosen names (e.g. components: {sfs: {...}}).
  std::vector<std::string> keys() const;

  /// Reject every key of this mapping that was not read, suggesting the closest declared key.
  void finish() const;
  /// finish(), then run `check` (a struct's validate(), which throws FieldError) and report its
  /// error here, at the field's key: the end of every "read a struct from YAML" function.
  template <class Check>
  void finish_and_check(Check&& check) const {
    finish();
    try {
      check();
    } catch (const FieldError& e) {
      fail(e);
    }
  }

  /// Throw a ConfigError located at `key` (or at this mapping when the key is absent).
  [[noreturn]] void fail(std::string_view key, const std::string& problem) const;
  /// Relocate a FieldError thrown by an algorithm or backend while validating values read from
  /// this mapping: "file:line:col: path.field: problem", located at the field's key when present.
  [[noreturn]] void fail(const FieldError& e) const;
  /// For keys an older file format had here: when `key` is present, fail at it saying what to
  /// write instead ("... is declared once now: write rover.cameras.front.mount {z_m, pitch_rad}").
  void reject_moved(std::string_view key, const std::string& write_instead) const;
  /// Location string "file:line:col" of `key` (or of this mapping).
  std::string where(std::string_view key = {}) const;
  std::string field_path(std::string_view key) const;

  const std::string& file() const { return file_; }
  const std::string& path() const { return path_; }
  const YAML::Node& node() const { return node_; }
  const std::shared_ptr<std::vector<ResolvedParam>>& sink() const { return sink_; }

 private:
  template <class T>
  T read(std::string_view key, const T* default_value, const ParamSpec& spec);
  void mark_used(std::string_view key) const;

  YAML::Node node_;
  std::string file_;
  std::string path_;
  std::shared_ptr<std::vector<ResolvedParam>> sink_;
  std::shared_ptr<std::vector<std::string>> used_;
};

/// A whole string as a 64-bit integer (decimal, 0x hexadecimal or 0 octal, as YAML and V4L2
/// controls write them); false if it is empty, has anything after the number or is out of range.
bool parse_integer(const std::string& s, std::int64_t& out);

/// Levenshtein-closest candidate, or empty when nothing is reasonably close.
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

extern template bool Params::get<bool>(std::string_view, const bool&, const ParamSpec&);
extern template int Params::get<int>(std::string_view, const int&, const ParamSpec&);
extern template std::int64_t Params::get<std::int64_t>(std::string_view, const std::int64_t&, const ParamSpec&);
extern template double Params::get<double>(std::string_view, const double&, const ParamSpec&);
extern template std::string Params::get<std::string>(std::string_view, const std::string&, const ParamSpec&);
extern template std::vector<double> Params::get<std::vector<double>>(std::string_view, const std::vector<double>&,
                                                                     const ParamSpec&);
extern template std::vector<std::string> Params::get<std::vector<std::string>>(std::string_view,
                                                                               const std::vector<std::string>&,
                                                                               const ParamSpec&);
extern template bool Params::require<bool>(std::string_view, const ParamSpec&);
extern template int Params::require<int>(std::string_view, const ParamSpec&);
extern template std::int64_t Params::require<std::int64_t>(std::string_view, const ParamSpec&);
extern template double Params::require<double>(std::string_view, const ParamSpec&);
extern template std::string Params::require<std::string>(std::string_view, const ParamSpec&);
extern template std::vector<double> Params::require<std::vector<double>>(std::string_view, const ParamSpec&);
extern template std::vector<std::string> Params::require<std::vector<std::string>>(std::string_view, const ParamSpec&);

}  // namespace regolith
