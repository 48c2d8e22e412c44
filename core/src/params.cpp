#include "regolith/core/params.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <limits>

#include "regolith/core/text_file.hpp"

namespace regolith {
namespace {

std::string range_text(const ParamSpec& s) {
  if (!s.choices.empty()) {
    std::string out = "one of ";
    for (std::size_t i = 0; i < s.choices.size(); ++i) out += (i ? "|" : "") + s.choices[i];
    return out;
  }
  if (s.min && s.max) return (s.min_exclusive ? "(" : "[") + number_text(*s.min) + ", " + number_text(*s.max) + "]";
  if (s.min) return (s.min_exclusive ? "> " : ">= ") + number_text(*s.min);
  if (s.max) return "<= " + number_text(*s.max);
  return {};
}

std::string render(const YAML::Node& n) {
  YAML::Emitter e;
  e.SetSeqFormat(YAML::Flow);
  e.SetMapFormat(YAML::Flow);
  e << n;
  return e.c_str();
}

template <class T>
struct TypeName;
template <>
struct TypeName<bool> {
  static constexpr const char* v = "bool";
};
template <>
struct TypeName<int> {
  static constexpr const char* v = "int";
};
template <>
struct TypeName<std::int64_t> {
  static constexpr const char* v = "int";
};
template <>
struct TypeName<double> {
  static constexpr const char* v = "double";
};
template <>
struct TypeName<std::string> {
  static constexpr const char* v = "string";
};
template <>
struct TypeName<std::vector<double>> {
  static constexpr const char* v = "double[]";
};
template <>
struct TypeName<std::vector<std::string>> {
  static constexpr const char* v = "string[]";
};

// Strict scalar conversions: yaml-cpp's own `as<int>` accepts "1.5" in some versions and `as<bool>`
// accepts "y"; we want exactly what the type says.
bool parse_bool(const std::string& s, bool& out) {
  if (s == "true" || s == "True" || s == "TRUE") {
    out = true;
    return true;
  }
  if (s == "false" || s == "False" || s == "FALSE") {
    out = false;
    return true;
  }
  return false;
}
bool parse_double(const std::string& s, double& out) {
  if (s.empty()) return false;
  if (s == ".nan" || s == ".NaN" || s == "nan") {
    out = std::numeric_limits<double>::quiet_NaN();
    return true;
  }
  if (s == ".inf" || s == "inf") {
    out = std::numeric_limits<double>::infinity();
    return true;
  }
  if (s == "-.inf" || s == "-inf") {
    out = -std::numeric_limits<double>::infinity();
    return true;
  }
  std::size_t pos = 0;
  try {
    out = std::stod(s, &pos);
  } catch (...) {
    return false;
  }
  return pos == s.size();
}

}  // namespace

bool parse_integer(const std::string& s, std::int64_t& out) {
  if (s.empty()) return false;
  std::size_t pos = 0;
  try {
    out = std::stoll(s, &pos, 0);
  } catch (...) {
    return false;
  }
  return pos == s.size();
}

Params Params::load_file(const std::string& path) {
  std::string text;
  try {
    text = read_text_file(path, "configuration file");
  } catch (const InputError& e) {
    throw ConfigError(e.what());
  }
  return load_string(text, path);
}

Params Params::load_string(const std::string& text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw ConfigError(name + ":" + std::to_string(e.mark.line + 1) + ":" + std::to_string(e.mark.column + 1) +
                      ": malformed YAML: " + e.msg);
  }
  if (!root || root.IsNull()) throw ConfigError(name + ": configuration is empty");
  if (!root.IsMap()) {
    throw ConfigError(name + ":" + std::to_string(root.Mark().line + 1) + ":" + std::to_string(root.Mark().column + 1) +
                      ": top level must be a mapping");
  }
  return Params(root, name, "", std::make_shared<std::vector<ResolvedParam>>());
}

Params::Params(YAML::Node node, std::string file, std::string path, std::shared_ptr<std::vector<ResolvedParam>> sink)
    : node_(std::move(node)),
      file_(std::move(file)),
      path_(std::move(path)),
      sink_(sink ? std::move(sink) : std::make_shared<std::vector<ResolvedParam>>()),
      used_(std::make_shared<std::vector<std::string>>()) {}

std::string Params::field_path(std::string_view key) const {
  if (key.empty()) return path_.empty() ? "<root>" : path_;
  if (path_.empty()) return std::string(key);
  return path_ + "." + std::string(key);
}

std::string Params::where(std::string_view key) const {
  YAML::Mark m = YAML::Mark::null_mark();
  if (!key.empty() && node_.IsMap()) {
    for (const auto& kv : node_) {
      if (kv.first.Scalar() == key) {
        m = kv.second.Mark();
        if (m.is_null()) m = kv.first.Mark();
        break;
      }
    }
  }
  if (m.is_null() && node_ && !node_.IsNull()) m = node_.Mark();
  if (m.is_null()) return file_;
  return file_ + ":" + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1);
}

void Params::fail(std::string_view key, const std::string& problem) const {
  throw ConfigError(where(key) + ": " + field_path(key) + ": " + problem);
}

void Params::fail(const FieldError& e) const {
  // Point at the key the field was read from when it is in this mapping ("hub_center_px" for
  // "hub_center_px.x"), else at the mapping; the path always names the whole field.
  const std::string& field = e.field();
  const std::string head = field.substr(0, field.find('.'));
  throw ConfigError(where(has(head) ? std::string_view(head) : std::string_view()) + ": " + field_path(field) + ": " +
                    e.problem());
}

void Params::reject_moved(std::string_view key, const std::string& write_instead) const {
  if (node_.IsMap() && node_[std::string(key)]) fail(key, "no longer read here: " + write_instead);
}

bool Params::has(std::string_view key) const {
  return node_.IsMap() && node_[std::string(key)] && !node_[std::string(key)].IsNull();
}

void Params::mark_used(std::string_view key) const {
  if (std::find(used_->begin(), used_->end(), key) == used_->end()) used_->emplace_back(key);
}

Params Params::child(std::string_view key) {
  mark_used(key);
  if (!node_.IsMap()) fail({}, "expected a mapping");
  YAML::Node c = node_[std::string(key)];
  if (!c || c.IsNull()) return Params(YAML::Node(YAML::NodeType::Map), file_, field_path(key), sink_);
  if (!c.IsMap()) fail(key, "expected a mapping");
  return Params(c, file_, field_path(key), sink_);
}

Params Params::require_child(std::string_view key) {
  if (!has(key)) fail(key, "required section is missing");
  return child(key);
}

std::vector<Params> Params::child_list(std::string_view key, bool required) {
  mark_used(key);
  std::vector<Params> out;
  if (!has(key)) {
    if (required) fail(key, "required list is missing");
    return out;
  }
  YAML::Node c = node_[std::string(key)];
  if (!c.IsSequence()) fail(key, "expected a list");
  std::size_t i = 0;
  for (const auto& item : c) {
    const std::string p = field_path(key) + "[" + std::to_string(i++) + "]";
    if (!item.IsMap()) {
      const auto m = item.Mark();
      throw ConfigError(file_ + ":" + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1) + ": " + p +
                        ": expected a mapping");
    }
    out.emplace_back(item, file_, p, sink_);
  }
  return out;
}

std::vector<std::string> Params::keys() const {
  std::vector<std::string> out;
  if (!node_.IsMap()) return out;
  for (const auto& kv : node_) out.push_back(kv.first.Scalar());
  return out;
}

void Params::finish() const {
  if (!node_.IsMap()) return;
  for (const auto& kv : node_) {
    const std::string k = kv.first.Scalar();
    if (std::find(used_->begin(), used_->end(), k) != used_->end()) continue;
    std::string msg = "unknown key";
    const std::string guess = did_you_mean(k, *used_);
    if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
    const auto m = kv.first.Mark();
    throw ConfigError(file_ + ":" + std::to_string(m.line + 1) + ":" + std::to_string(m.column + 1) + ": " +
                      field_path(k) + ": " + msg);
  }
}

template <class T>
T Params::read(std::string_view key, const T* default_value, const ParamSpec& spec) {
  mark_used(key);
  if (!node_.IsMap() && !(node_.IsNull())) fail({}, "expected a mapping");
  const bool present = has(key);
  T value{};
  if (!present) {
    if (default_value == nullptr) fail(key, std::string("required ") + TypeName<T>::v + " is missing");
    value = *default_value;
  } else {
    const YAML::Node n = node_[std::string(key)];
    auto bad = [&](const std::string& what) { fail(key, "expected " + what + ", got '" + render(n) + "'"); };
    if constexpr (std::is_same_v<T, bool>) {
      if (!n.IsScalar() || !parse_bool(n.Scalar(), value)) bad("true or false");
    } else if constexpr (std::is_same_v<T, int> || std::is_same_v<T, std::int64_t>) {
      std::int64_t v = 0;
      if (!n.IsScalar() || !parse_integer(n.Scalar(), v)) bad("an integer");
      if constexpr (std::is_same_v<T, int>) {
        if (v < std::numeric_limits<int>::min() || v > std::numeric_limits<int>::max()) bad("a 32-bit integer");
      }
      value = static_cast<T>(v);
    } else if constexpr (std::is_same_v<T, double>) {
      if (!n.IsScalar() || !parse_double(n.Scalar(), value)) bad("a number");
      if (std::isnan(value)) fail(key, "must be a number, got NaN");
    } else if constexpr (std::is_same_v<T, std::string>) {
      if (!n.IsScalar()) bad("a string");
      value = n.Scalar();
    } else if constexpr (std::is_same_v<T, std::vector<double>>) {
      if (!n.IsSequence()) bad("a list of numbers");
      for (const auto& e : n) {
        double d = 0;
        if (!e.IsScalar() || !parse_double(e.Scalar(), d) || std::isnan(d)) bad("a list of numbers");
        value.push_back(d);
      }
    } else if constexpr (std::is_same_v<T, std::vector<std::string>>) {
      if (!n.IsSequence()) bad("a list of strings");
      for (const auto& e : n) {
        if (!e.IsScalar()) bad("a list of strings");
        value.push_back(e.Scalar());
      }
    }
  }

  // Range and choice checks (also applied to defaults: a bad default is a programming error we
  // still report the same way).
  auto check_num = [&](double v, const std::string& what) {
    if (spec.min && (spec.min_exclusive ? !(v > *spec.min) : !(v >= *spec.min)))
      fail(key, what + " must be " + (spec.min_exclusive ? "> " : ">= ") + number_text(*spec.min) + " (got " +
                    number_text(v) + ")");
    if (spec.max && !(v <= *spec.max))
      fail(key, what + " must be <= " + number_text(*spec.max) + " (got " + number_text(v) + ")");
  };
  std::string rendered;
  if constexpr (std::is_same_v<T, bool>) {
    rendered = value ? "true" : "false";
  } else if constexpr (std::is_arithmetic_v<T>) {
    check_num(static_cast<double>(value), "value");
    rendered = number_text(static_cast<double>(value));
  } else if constexpr (std::is_same_v<T, std::string>) {
    if (!spec.choices.empty() && std::find(spec.choices.begin(), spec.choices.end(), value) == spec.choices.end()) {
      std::string msg = "'" + value + "' is not " + range_text(spec);
      const std::string guess = did_you_mean(value, spec.choices);
      if (!guess.empty()) msg += " (did you mean '" + guess + "'?)";
      fail(key, msg);
    }
    rendered = value;
  } else if constexpr (std::is_same_v<T, std::vector<double>>) {
    rendered = "[";
    for (std::size_t i = 0; i < value.size(); ++i) {
      check_num(value[i], "element " + std::to_string(i));
      rendered += (i ? ", " : "") + number_text(value[i]);
    }
    rendered += "]";
  } else {
    rendered = "[";
    for (std::size_t i = 0; i < value.size(); ++i) {
      if (!spec.choices.empty() &&
          std::find(spec.choices.begin(), spec.choices.end(), value[i]) == spec.choices.end()) {
        fail(key, "element " + std::to_string(i) + " '" + value[i] + "' is not " + range_text(spec));
      }
      rendered += (i ? ", " : "") + value[i];
    }
    rendered += "]";
  }
  // A key read twice (e.g. a device name resolved by two helpers) is listed once.
  ResolvedParam rp{field_path(key),  TypeName<T>::v,        rendered, std::string(spec.unit),
                   range_text(spec), std::string(spec.doc), !present};
  const auto same =
      std::find_if(sink_->begin(), sink_->end(), [&](const ResolvedParam& r) { return r.path == rp.path; });
  if (same != sink_->end())
    *same = std::move(rp);
  else
    sink_->push_back(std::move(rp));
  return value;
}

template <class T>
T Params::get(std::string_view key, const T& default_value, const ParamSpec& spec) {
  return read<T>(key, &default_value, spec);
}
template <class T>
T Params::require(std::string_view key, const ParamSpec& spec) {
  return read<T>(key, nullptr, spec);
}

#define REGOLITH_PARAMS_INSTANTIATE(T)                                     \
  template T Params::get<T>(std::string_view, const T&, const ParamSpec&); \
  template T Params::require<T>(std::string_view, const ParamSpec&);
REGOLITH_PARAMS_INSTANTIATE(bool)
REGOLITH_PARAMS_INSTANTIATE(int)
REGOLITH_PARAMS_INSTANTIATE(std::int64_t)
REGOLITH_PARAMS_INSTANTIATE(double)
REGOLITH_PARAMS_INSTANTIATE(std::string)
REGOLITH_PARAMS_INSTANTIATE(std::vector<double>)
REGOLITH_PARAMS_INSTANTIATE(std::vector<std::string>)
#undef REGOLITH_PARAMS_INSTANTIATE

std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates) {
  std::string best;
  std::size_t best_d = std::numeric_limits<std::size_t>::max();
  for (const auto& c : candidates) {
    std::vector<std::size_t> prev(c.size() + 1), cur(c.size() + 1);
    for (std::size_t j = 0; j <= c.size(); ++j) prev[j] = j;
    for (std::size_t i = 1; i <= word.size(); ++i) {
      cur[0] = i;
      for (std::size_t j = 1; j <= c.size(); ++j) {
        const std::size_t sub = prev[j - 1] + (std::tolower(word[i - 1]) == std::tolower(c[j - 1]) ? 0 : 1);
        cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
      }
      std::swap(prev, cur);
    }
    if (prev[c.size()] < best_d) {
      best_d = prev[c.size()];
      best = c;
    }
  }
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  return best_d <= limit ? best : std::string{};
}

}  // namespace regolith
