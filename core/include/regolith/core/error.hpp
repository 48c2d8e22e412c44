#pragma once
// The error types of regolith. Header-only and standard-library-only, so framework-free algorithm
// libraries can throw them (target regolith::errors) without depending on YAML or the runtime.
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>

namespace regolith {

/// A number as messages quote it: six significant digits, exponent form when very large or small
/// ("-3", "0.005", "1e+308", "1e-09"; std::to_string gave 309 digits or "0.000000").
inline std::string number_text(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

/// A configuration or input problem found before anything runs. The message is complete and
/// user-facing, e.g. "config/mock_rover.yaml:12:5: rate_groups[0].period_ms: must be > 0 (got -5)".
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Bad input data (an image, a log line, a CSV row): the message names the file / line / frame.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "This field is wrong", thrown by code that knows the field but not where it was written: an
/// algorithm's parameter struct (`SfsParams.iterations`), a backend's option check (`fourcc`).
/// The layer that read the field from a file relocates it with `Params::fail(const FieldError&)`,
/// which turns it into a ConfigError "file:line:col: components.sfs.iterations: must be >= 1"
/// pointing at the key. what() is "owner.field: problem" ("field: problem" without an owner).
/// Derives from std::invalid_argument, the standard type for a bad argument.
class FieldError : public std::invalid_argument {
 public:
  FieldError(std::string owner, std::string field, std::string problem)
      : std::invalid_argument((owner.empty() ? std::string() : owner + ".") + field + ": " + problem),
        owner_(std::move(owner)),
        field_(std::move(field)),
        problem_(std::move(problem)) {}

  /// The struct or function the field belongs to ("SfsParams"), or empty.
  const std::string& owner() const noexcept { return owner_; }
  /// The field, dotted for nested ones ("hub_center_px.x"); keys in YAML use the same names.
  const std::string& field() const noexcept { return field_; }
  /// What is wrong, with the offending value when it helps ("must be > 0 (got -5)").
  const std::string& problem() const noexcept { return problem_; }

 private:
  std::string owner_, field_, problem_;
};

}  // namespace regolith
