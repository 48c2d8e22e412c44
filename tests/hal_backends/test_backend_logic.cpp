// Host-side logic of the real HAL backends: no device needed (sequence gaps, control names, device
// selection, error-frame decoding, YAML validation, start-up errors for absent devices). The
// back-off and the error types they share are tested with regolith::hal (tests/hal/test_device.cpp).
#include <filesystem>

#include <linux/can.h>
#include <linux/can/error.h>

#include <gtest/gtest.h>

#include "error_of.hpp"
#include "regolith/hal_libcamera/libcamera.hpp"
#include "regolith/hal_socketcan/socketcan.hpp"
#include "regolith/hal_v4l2/v4l2.hpp"

using namespace regolith;
using namespace regolith::hal;

namespace {

using regolith::testing::error_of;

#define EXPECT_CONTAINS(haystack, needle) \
  EXPECT_NE(std::string(haystack).find(needle), std::string::npos) << "message: " << (haystack)

}  // namespace

TEST(V4l2Logic, SequenceGapCountsMissingFrames) {
  using v4l2::sequence_gap;
  EXPECT_EQ(sequence_gap(false, 0, 17), 0u);  // first frame
  EXPECT_EQ(sequence_gap(true, 4, 5), 0u);
  EXPECT_EQ(sequence_gap(true, 4, 8), 3u);
  EXPECT_EQ(sequence_gap(true, 0xFFFFFFFEu, 1u), 2u);  // across the 32-bit wrap
  EXPECT_EQ(sequence_gap(true, 500, 0), 0u);           // driver restarted numbering
  EXPECT_EQ(sequence_gap(true, 9, 9), 0u);
}

TEST(V4l2Logic, ControlNamesFollowV4l2Ctl) {
  EXPECT_EQ(v4l2::normalise_control_name("Exposure Time, Absolute"), "exposure_time_absolute");
  EXPECT_EQ(v4l2::normalise_control_name("Gain"), "gain");
  EXPECT_EQ(v4l2::normalise_control_name("White Balance Temperature, Auto"), "white_balance_temperature_auto");
  EXPECT_EQ(v4l2::normalise_control_name("  Inject V4L2_BUF_FLAG_ERROR "), "inject_v4l2_buf_flag_error");
}

TEST(V4l2Logic, SelectDeviceByCardOrBusInfo) {
  std::vector<v4l2::DeviceInfo> devs(3);
  devs[0] = {"/dev/video0", "uvcvideo", "Logitech C920", "usb-0000:00:14.0-1", true, {}};
  devs[1] = {"/dev/video1", "uvcvideo", "Logitech C920", "usb-0000:00:14.0-1", false, {}};  // metadata node
  devs[2] = {"/dev/video2", "vivid", "vivid", "platform:vivid-000", true, {}};
  EXPECT_EQ(v4l2::select_device(devs, "", "vivid", ""), "/dev/video2");
  EXPECT_EQ(v4l2::select_device(devs, "", "", "usb-0000:00:14.0-1"), "/dev/video0");
  EXPECT_EQ(v4l2::select_device(devs, "/dev/video2", "vivid", ""), "/dev/video2");
  const std::string msg = error_of([&] { v4l2::select_device(devs, "", "Arducam", ""); });
  EXPECT_CONTAINS(msg, "no video capture device matches card 'Arducam'");
  EXPECT_CONTAINS(msg, "/dev/video0 card 'Logitech C920' bus_info 'usb-0000:00:14.0-1'");
  EXPECT_EQ(msg.find("/dev/video1"), std::string::npos) << "non-capture nodes are not offered: " << msg;
  EXPECT_CONTAINS(error_of([&] { v4l2::select_device(devs, "/dev/video1", "", ""); }), "device '/dev/video1'");
}

TEST(V4l2Config, YamlIsValidatedWithLocations) {
  auto p = Params::load_string(
      "backend: v4l2\ndevice: /dev/video0\nwidth: 640\nheight: 360\nfourcc: YUYV\n"
      "pixel_format: bgr8\nrate: 25\nbuffers: 3\ncontrols:\n  brightness: 200\n  test_pattern: 75% Colorbar\n",
      "cam.yaml");
  p.get<std::string>("backend", "");
  const v4l2::Config c = v4l2::config_from_params(p);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.output, PixelFormat::kBgr8);
  EXPECT_EQ(c.buffers, 3);
  ASSERT_EQ(c.controls.size(), 2u);
  EXPECT_EQ(c.controls[1].name, "test_pattern");
  EXPECT_EQ(c.controls[1].value, "75% Colorbar");

  auto bad_fourcc = Params::load_string("device: /dev/video0\nfourcc: H264\n", "cam.yaml");
  const std::string m1 = error_of([&] { v4l2::config_from_params(bad_fourcc); });
  EXPECT_CONTAINS(m1, "cam.yaml:2:9: fourcc: 'H264' is not one of");
  auto no_device = Params::load_string("width: 640\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { v4l2::config_from_params(no_device); }),
                  "give device (e.g. /dev/video0), card or bus_info");
  auto typo = Params::load_string("device: /dev/video0\nbufers: 4\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { v4l2::config_from_params(typo); }), "did you mean 'buffers'");
  auto few = Params::load_string("device: /dev/video0\nbuffers: 1\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { v4l2::config_from_params(few); }), "buffers: value must be >= 2 (got 1)");
}

TEST(V4l2Camera, MissingDeviceIsAStartupErrorNamingIt) {
  BackendRegistry reg;
  v4l2::register_v4l2_backend(reg);
  auto p = Params::load_string("backend: v4l2\ndevice: /dev/video97\n", "rover.yaml");
  DeviceContext ctx;
  ctx.id = "front";
  // absent now, may appear later (a USB camera at boot): unavailable, not a configuration error
  const std::string msg = error_of<DeviceUnavailableError>([&] { reg.make_camera(p, ctx); });
  EXPECT_CONTAINS(msg,
                  "rover.yaml:2:9: device: v4l2 camera 'front' (/dev/video97): cannot open: No such file or directory");
  auto by_card = Params::load_string("backend: v4l2\ncard: No Such Camera\n", "rover.yaml");
  const std::string by_card_msg = error_of<DeviceUnavailableError>([&] { reg.make_camera(by_card, ctx); });
  EXPECT_CONTAINS(by_card_msg, "rover.yaml:2:7: card: v4l2 camera 'front': ");
  EXPECT_CONTAINS(by_card_msg, "no video capture device matches card 'No Such Camera'");
}

TEST(V4l2Camera, NonVideoNodeIsRejected) {
  v4l2::Config c;
  c.device = "/dev/null";
  DeviceContext ctx;
  ctx.id = "front";
  // the node is there but cannot capture: a configuration error (not retried)
  const std::string msg = error_of<DeviceConfigError>([&] { v4l2::V4l2Camera cam(c, ctx); });
  EXPECT_CONTAINS(msg, "v4l2 camera 'front' (/dev/null): not a V4L2 device");
  BackendRegistry reg;
  v4l2::register_v4l2_backend(reg);
  auto p = Params::load_string("backend: v4l2\ndevice: /dev/null\n", "rover.yaml");
  EXPECT_CONTAINS(error_of<ConfigError>([&] { reg.make_camera(p, ctx); }),
                  "rover.yaml:2:9: device: v4l2 camera 'front' (/dev/null): not a V4L2 device");
}

TEST(SocketCanLogic, ErrorFramesDecodeIntoClasses) {
  CanFrame f;
  f.error = true;
  f.len = CAN_ERR_DLC;
  f.id = CAN_ERR_BUSOFF;
  auto e = socketcan::decode_error_frame(f);
  EXPECT_TRUE(e.bus_off);
  EXPECT_FALSE(e.error_passive);
  EXPECT_EQ(e.describe(), "bus-off");

  f.id = CAN_ERR_CRTL | CAN_ERR_CNT;
  f.data[1] = CAN_ERR_CRTL_TX_PASSIVE | CAN_ERR_CRTL_RX_WARNING;
  f.data[6] = 130;
  f.data[7] = 97;
  e = socketcan::decode_error_frame(f);
  EXPECT_TRUE(e.controller);
  EXPECT_TRUE(e.error_passive);
  EXPECT_TRUE(e.error_warning);
  EXPECT_FALSE(e.bus_off);
  EXPECT_EQ(e.tx_error_count, 130);
  EXPECT_EQ(e.rx_error_count, 97);
  EXPECT_EQ(e.describe(), "error-passive, error-warning (tx errors 130, rx errors 97)");

  f = CanFrame{};
  f.error = true;
  f.len = 8;
  f.id = CAN_ERR_LOSTARB;
  f.data[0] = 7;
  e = socketcan::decode_error_frame(f);
  EXPECT_TRUE(e.lost_arbitration);
  EXPECT_EQ(e.arbitration_bit, 7);
  EXPECT_EQ(e.describe(), "lost arbitration (bit 7)");

  f.id = CAN_ERR_CRTL;
  f.data[1] = CAN_ERR_CRTL_RX_OVERFLOW;
  e = socketcan::decode_error_frame(f);
  EXPECT_TRUE(e.rx_overflow);
  EXPECT_EQ(e.describe(), "rx overflow");

  f.id = CAN_ERR_PROT | CAN_ERR_ACK | CAN_ERR_RESTARTED;
  f.len = 0;  // short error frame: payload bytes read as 0
  e = socketcan::decode_error_frame(f);
  EXPECT_TRUE(e.protocol);
  EXPECT_TRUE(e.no_ack);
  EXPECT_TRUE(e.restarted);
  EXPECT_EQ(e.describe(), "protocol violation, no ACK, controller restarted");
}

TEST(SocketCanConfig, WheelsAndTransducersFromYaml) {
  auto p = Params::load_string(R"(interface: vcan0
wheels:
  front_left: {id: 0x101, length: 4, scale: 0.001}
  front_right: {id: 0x101, byte_offset: 4, length: 4, scale: 0.001}
transducers:
  sinkage: {id: 0x200, length: 2, signed: false, wrap: false, scale: 1.0e-5}
stale_timeout: 0.5
command: {enabled: true, id: 0x300}
)",
                               "enc.yaml");
  const auto c = socketcan::config_from_params(p);
  ASSERT_EQ(c.wheels.size(), 2u);
  EXPECT_EQ(c.wheels[1].name, "front_right");
  EXPECT_EQ(c.wheels[1].byte_offset, 4);
  ASSERT_EQ(c.transducers.size(), 1u);
  EXPECT_EQ(c.transducers[0].id, 0x200u);
  EXPECT_FALSE(c.transducers[0].wrap);
  EXPECT_TRUE(c.tx_enabled);
  EXPECT_EQ(c.tx_id, 0x300u);

  auto dup = Params::load_string("interface: vcan0\nwheels:\n  a: {id: 1}\ntransducers:\n  a: {id: 2}\n", "enc.yaml");
  EXPECT_CONTAINS(error_of([&] { socketcan::config_from_params(dup); }), "name 'a' is used twice");
  auto fd_offset =
      Params::load_string("interface: vcan0\nwheels:\n  a: {id: 1, byte_offset: 6, length: 4}\n", "enc.yaml");
  EXPECT_CONTAINS(error_of([&] { socketcan::config_from_params(fd_offset); }), "must fit a classic CAN payload (8)");
  auto none = Params::load_string("interface: vcan0\n", "enc.yaml");
  EXPECT_CONTAINS(error_of([&] { socketcan::config_from_params(none); }), "at least one wheel or transducer");
  auto long_name = Params::load_string("interface: a_very_long_interface_name\nwheels:\n  a: {id: 1}\n", "enc.yaml");
  EXPECT_CONTAINS(error_of([&] { socketcan::config_from_params(long_name); }),
                  "enc.yaml:1:12: interface: must be a network interface name");
}

TEST(SocketCan, AbsentInterfaceIsAStartupErrorNamingIt) {
  BackendRegistry reg;
  socketcan::register_socketcan_backend(reg);
  auto p = Params::load_string("backend: socketcan\ninterface: rgcan7\nwheels:\n  fl: {id: 0x101}\n", "rover.yaml");
  DeviceContext ctx;
  ctx.id = "wheels";
  // the interface is looked up before the CAN socket is created: the same on a kernel without SocketCAN
  const std::string msg = error_of<DeviceUnavailableError>([&] { reg.make_encoders(p, ctx); });
  EXPECT_CONTAINS(
      msg, "rover.yaml:2:12: interface: socketcan 'wheels': interface 'rgcan7' does not exist (CAN interfaces: ");
}

TEST(SocketCan, NonCanInterfaceIsRejected) {
  socketcan::Config c;
  c.interface = "lo";
  c.wheels.push_back(CanSignal{"fl", 0x101});
  DeviceContext ctx;
  ctx.id = "wheels";
  const std::string msg = error_of<DeviceConfigError>([&] { socketcan::SocketCanEncoders enc(c, ctx); });
  EXPECT_CONTAINS(msg, "socketcan 'wheels': interface 'lo' is not a CAN interface (link type 772");
}

TEST(LibcameraConfig, YamlIsValidated) {
  auto p = Params::load_string(
      "camera: /base/platform/vimc.0\nwidth: 960\nheight: 720\nformat: BGR888\n"
      "controls:\n  Brightness: 0.5\n",
      "cam.yaml");
  const auto c = libcam::config_from_params(p);
  EXPECT_EQ(c.pixel_format, "BGR888");
  EXPECT_EQ(c.output, PixelFormat::kBgr8);
  ASSERT_EQ(c.controls.size(), 1u);
  EXPECT_EQ(c.controls[0].second, "0.5");
  EXPECT_EQ(c.rate_hz, 0.0) << "no rate: the camera's own, unknown";
  auto rated = Params::load_string("rate: 7.5\n", "cam.yaml");
  EXPECT_EQ(libcam::config_from_params(rated).rate_hz, 7.5);
  auto bad_rate = Params::load_string("rate: -2\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { libcam::config_from_params(bad_rate); }), "cam.yaml:1:7: rate: ");
  auto bad_role = Params::load_string("role: selfie\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { libcam::config_from_params(bad_role); }),
                  "cam.yaml:1:7: role: 'selfie' is not one of");
  auto bad_format = Params::load_string("format: NV12\n", "cam.yaml");
  EXPECT_CONTAINS(error_of([&] { libcam::config_from_params(bad_format); }), "format: 'NV12' is not one of");
}
