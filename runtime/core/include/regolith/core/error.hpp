#pragma once
#include <stdexcept>
#include <string>

namespace regolith {

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

}  // namespace regolith
