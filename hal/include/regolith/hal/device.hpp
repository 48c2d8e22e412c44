#pragma once
// Shared by the hardware backends (v4l2, libcamera, socketcan): the error a backend throws while
// configuring its device, and the back-off of the re-open loops that run afterwards.
#include <stdexcept>
#include <string>
#include <utility>

#include "regolith/core/time.hpp"

namespace regolith::hal {

/// Error in the configuration found while talking to the device; `field` is the YAML key (the
/// backend's factory turns it into a ConfigError located at that key).
class DeviceConfigError : public std::runtime_error {
 public:
  DeviceConfigError(std::string field, const std::string& msg) : std::runtime_error(msg), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

/// Exponential back-off for re-opening a device: `initial`, doubled per failure up to `max`;
/// reset() after a success.
class Backoff {
 public:
  Backoff(TimeNs initial, TimeNs max) : initial_(initial), max_(max), next_(initial) {}
  TimeNs next() {
    const TimeNs d = next_;
    next_ = next_ > max_ / 2 ? max_ : next_ * 2;
    return d;
  }
  void reset() { next_ = initial_; }

 private:
  TimeNs initial_, max_, next_;
};

}  // namespace regolith::hal
