#include "regolith/hal/unopened.hpp"

#include <stdexcept>

namespace regolith::hal {
namespace {

class UnopenedCamera final : public Camera {
 public:
  UnopenedCamera(std::string id, CameraFormat f) : id_(std::move(id)), format_(f) {}
  const std::string& id() const override { return id_; }
  CameraFormat format() const override { return format_; }
  void start() override { throw std::runtime_error("camera '" + id_ + "' was configured for validation only"); }
  void stop() override {}
  bool latest(TimeNs, FrameLease&) override { return false; }
  CameraStats stats() const override { return {}; }

 private:
  std::string id_;
  CameraFormat format_;
};

class UnopenedEncoders final : public WheelEncoders {
 public:
  UnopenedEncoders(std::string id, std::vector<std::string> names) : id_(std::move(id)), names_(std::move(names)) {}
  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return names_; }
  void start() override { throw std::runtime_error("encoders '" + id_ + "' were configured for validation only"); }
  void stop() override {}
  bool latest(std::size_t, TimeNs, AngleSample&) const override { return false; }
  bool angle_at(std::size_t, TimeNs, double&) const override { return false; }
  EncoderStats stats() const override { return {}; }

 private:
  std::string id_;
  std::vector<std::string> names_;
};

}  // namespace

std::unique_ptr<Camera> make_unopened_camera(const std::string& id, const CameraFormat& format) {
  return std::make_unique<UnopenedCamera>(id, format);
}
std::unique_ptr<WheelEncoders> make_unopened_encoders(const std::string& id, std::vector<std::string> wheel_names) {
  return std::make_unique<UnopenedEncoders>(id, std::move(wheel_names));
}

}  // namespace regolith::hal
