// An out-of-tree regolith application: its own wheel-encoder backend (`ramp`: every wheel turns at
// `speed_rad_s`) and its own component (`odometer`: distance = mean wheel angle x radius), beside
// the built-in joint_state_publisher and health components, from a YAML deployment, for 5 s of
// simulated time. Exit 0 when the distance is what the backend turned.
#include <atomic>
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "regolith/hal/registry.hpp"
#include "regolith/runtime/application.hpp"
#include "regolith/runtime/component.hpp"

using namespace regolith;

namespace {

class RampEncoders final : public hal::WheelEncoders {
 public:
  RampEncoders(std::string id, std::vector<std::string> wheels, double speed, Clock* clock)
      : id_(std::move(id)), wheels_(std::move(wheels)), speed_(speed), clock_(clock) {}
  const std::string& id() const override { return id_; }
  const std::vector<std::string>& wheel_names() const override { return wheels_; }
  void start() override { t0_ = clock_->now(); }
  void stop() override {}
  bool latest(std::size_t, TimeNs now, hal::AngleSample& out) const override {
    out = {now, speed_ * to_seconds(now - t0_)};
    return true;
  }
  bool angle_at(std::size_t, TimeNs t, double& a) const override {
    a = speed_ * to_seconds(t - t0_);
    return true;
  }
  hal::EncoderStats stats() const override { return {}; }

 private:
  std::string id_;
  std::vector<std::string> wheels_;
  double speed_;
  Clock* clock_;
  TimeNs t0_ = 0;
};

class Odometer final : public runtime::Component {
 public:
  void configure(Params& p, runtime::Context& ctx) override {
    enc_ = &ctx.encoders(p, "encoders");
    radius_ =
        p.get<double>("wheel_radius_m", 0.1, {.unit = "m", .min = 0.0, .min_exclusive = true, .doc = "wheel radius"});
  }
  void step(const runtime::CycleInfo& cycle) override {
    double sum = 0;
    for (std::size_t w = 0; w < enc_->wheel_count(); ++w) {
      hal::AngleSample s;
      if (enc_->latest(w, cycle.now, s)) sum += s.angle;
    }
    distance_m_ = radius_ * sum / static_cast<double>(enc_->wheel_count());
  }
  std::string result() const override { return "distance " + std::to_string(distance_m_) + " m"; }
  double distance_m() const { return distance_m_; }

 private:
  const hal::WheelEncoders* enc_ = nullptr;
  double radius_ = 0.1, distance_m_ = 0.0;
};

const char* kDeployment = R"(name: consumer_rover
dds: {enabled: false}
devices:
  encoders:
    wheels: {backend: ramp, wheels: [left, right], speed_rad_s: 2.0}
rate_groups:
  - {name: io, rate_hz: 50, members: [joints, odometer]}
  - {name: health, rate_hz: 1, members: [health]}
components:
  joints: {type: joint_state_publisher, encoders: wheels}
  odometer: {type: odometer, encoders: wheels, wheel_radius_m: 0.125}
  health: {type: health}
)";

}  // namespace

int main() {
  runtime::register_builtin_components();
  hal::BackendRegistry::instance().add_encoders(
      "ramp", "wheels turning at a constant speed", [](Params& p, const hal::DeviceContext& ctx) {
        auto wheels = p.require<std::vector<std::string>>("wheels");
        const double speed = p.get<double>("speed_rad_s", 1.0, {.unit = "rad/s", .doc = "wheel speed"});
        return std::make_unique<RampEncoders>(ctx.id, wheels, speed, ctx.clock);
      });
  runtime::ComponentRegistry::instance().add("odometer", "distance from the mean wheel angle",
                                             [] { return std::make_unique<Odometer>(); });
  try {
    auto app = runtime::Application::load(Params::load_string(kDeployment, "consumer.yaml"), {.sim_time = true});
    std::atomic<bool> stop{false};
    app->start();
    app->run(5 * kNsPerSec, stop);
    app->stop();
    for (const auto* c : app->view().components) std::printf("%-10s %s\n", c->name().c_str(), c->result().c_str());
    const auto* odo = dynamic_cast<const Odometer*>(app->view().components[1]);
    const double want = 0.125 * 2.0 * 5.0;
    if (odo == nullptr || std::abs(odo->distance_m() - want) > 1e-9) {
      std::printf("FAIL: distance %.6f m, expected %.6f m\n", odo ? odo->distance_m() : -1.0, want);
      return 1;
    }
    std::printf("OK: %.3f m in 5 simulated seconds\n", want);
    return 0;
  } catch (const std::exception& e) {
    std::printf("FAIL: %s\n", e.what());
    return 1;
  }
}
