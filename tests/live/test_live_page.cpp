// The built-in live page (runtime/live/web) served by FoxgloveServer on its WebSocket port (label
// integration: loopback sockets, DDS, child processes): the static files over plain HTTP (types,
// 404s, no way out of the web root) while the protocol keeps working; the page's CDR decoders
// (cdr.js, run by node) against samples serialized by Cyclone DDS and relayed here, every field
// compared with the runtime's own JSON rendering; and, when Debian's chromium is installed, the
// page rendered headless against a fake rover: panels filled (DOM) and a non-blank screenshot.
#include <atomic>
#include <cctype>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "child_process.hpp"
#include "dds_test_util.hpp"
#include "regolith/dds/json.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/live/dds_relay.hpp"
#include "regolith/live/web_root.hpp"
#include "temp_dir.hpp"
#include "ws_test_client.hpp"

namespace {

namespace fs = std::filesystem;
namespace rt = regolith::testing;
namespace rd = regolith::dds;
namespace rl = regolith::live;
namespace m = regolith::msgs;
using nlohmann::json;
using regolith::live::testing::WsClient;

constexpr std::int64_t kEpochNs = 1764000000LL * 1000000000LL;  // plausible wall-clock stamps
constexpr double kSoilK = 812345.6;                             // shown as 812.3 kPa/m^n

struct HttpReply {
  int status = 0;
  std::string content_type;
  std::string body;
  std::string head;  ///< status line and headers
};

/// The value of header `name` (lower case) in an HTTP head; "" when absent. Names are
/// case-insensitive and the space after the colon optional (chromium's DevTools omits it).
std::string header(const std::string& head, const std::string& name) {
  std::string low = head;
  for (char& ch : low) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  const auto at = low.find("\r\n" + name + ":");
  if (at == std::string::npos) return {};
  const auto begin = head.find_first_not_of(' ', at + name.size() + 3);
  return head.substr(begin, head.find("\r\n", begin) - begin);
}

/// One HTTP/1.1 request over a plain socket, the target sent byte for byte (no normalisation).
HttpReply http(std::uint16_t port, const std::string& target, const std::string& method = "GET",
               const std::string& extra_headers = "") {
  HttpReply r;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_port = htons(port);
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return r;
  }
  const std::string req =
      method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n" + extra_headers + "\r\n";
  if (send(fd, req.data(), req.size(), MSG_NOSIGNAL) != static_cast<ssize_t>(req.size())) {
    close(fd);
    return r;
  }
  std::string resp;
  char buf[4096];
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  for (;;) {
    pollfd p{fd, POLLIN, 0};
    if (std::chrono::steady_clock::now() > end || poll(&p, 1, 1000) < 0) break;
    if (p.revents == 0) continue;
    const ssize_t n = recv(fd, buf, sizeof buf, 0);
    if (n <= 0) break;
    resp.append(buf, static_cast<std::size_t>(n));
    // Complete when Content-Length says so (header names are case-insensitive), else at close.
    const auto head_end = resp.find("\r\n\r\n");
    if (head_end == std::string::npos) continue;
    const std::string length = header(resp.substr(0, head_end), "content-length");
    if (!length.empty() && resp.size() >= head_end + 4 + std::stoul(length)) break;
  }
  close(fd);
  const auto head_end = resp.find("\r\n\r\n");
  if (resp.rfind("HTTP/1.1 ", 0) != 0 || head_end == std::string::npos) return r;
  r.status = std::stoi(resp.substr(9, 3));
  r.content_type = header(resp.substr(0, head_end), "content-type");
  r.body = resp.substr(head_end + 4);
  r.head = resp.substr(0, head_end + 2);
  return r;
}

rl::FoxgloveServerOptions options(const std::string& web_root) {
  rl::FoxgloveServerOptions o;
  o.port = 0;
  o.web_root = web_root;
  return o;
}

std::vector<rl::Channel> one_channel() {
  return {{3, "/t/a", "cdr", "std_msgs/msg/String", "string data\n", "ros2msg"}};
}

json read_json(WsClient& c) {
  auto f = c.read();
  if (!f || f->opcode != 1) return json();
  return json::parse(f->payload, nullptr, false);
}

/// Polls `pred` every 50 ms up to `timeout` (the browser is a separate process: no hurry).
template <class Pred>
bool until(Pred pred, std::chrono::seconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return pred();
}

/// A rover that is not there: the topics the page shows, published over DDS with values that are
/// a function of the cycle i (cycle 0 repeated = identical samples). `last` keeps each topic's
/// last sample as rendered by the runtime's own to_json (the decoders' reference).
class FakeRover {
 public:
  static constexpr std::uint32_t kCols = 40, kRows = 30;  // world map: cells along y, along x

  explicit FakeRover(rd::Participant& p) {
    diag_ = make<m::diagnostic_msgs::DiagnosticArray>(p, "/diagnostics", [](auto& s) {
      rd::reserve(s, rd::DiagnosticArrayCapacity{3, 8, 64, 32});
    });
    sinkage_ = make<m::regolith_msgs::WheelSinkage>(p, "terrain/wheel_sinkage", [](auto& s) {
      rd::reserve(s, rd::WheelSinkageCapacity{4, 32, 32});
    });
    soil_ = make<m::regolith_msgs::SoilStiffness>(p, "terrain/soil",
                                                  [](auto& s) { rd::reserve(s, rd::SoilStiffnessCapacity{}); });
    map_ = make<m::grid_map_msgs::GridMap>(p, "terrain/world_map", [](auto& s) {
      rd::reserve(s, rd::GridMapCapacity{2, 1, kRows, kCols, 32, 32});
    });
    rocks_ = make<m::regolith_msgs::RockArray>(p, "terrain/rocks", [](auto& s) {
      rd::reserve(s, rd::RockArrayCapacity{3, 1, 32, 32});
    });
    world_rocks_ = make<m::vision_msgs::Detection3DArray>(p, "terrain/world_rocks", [](auto& s) {
      rd::reserve(s, rd::Detection3DArrayCapacity{2, 1, 32, 32});
    });
    odom_ = make<m::nav_msgs::Odometry>(p, "odom", [](auto& s) { rd::reserve(s, 32); });
    // a camera preview as camera_preview publishes it: a 160x120 JPEG with a red box
    cv::Mat img(120, 160, CV_8UC3, cv::Scalar(90, 90, 90));
    cv::rectangle(img, {60, 40}, {100, 80}, cv::Scalar(0, 0, 255), 2);
    cv::imencode(".jpg", img, jpeg_);
    const auto cap = static_cast<std::uint32_t>(jpeg_.size());
    preview_ = make<m::sensor_msgs::CompressedImage>(p, "preview/rocks/compressed",
                                                     [cap](auto& s) { rd::reserve(s, cap, 16, 32); });
    wheel_preview_ = make<m::sensor_msgs::CompressedImage>(p, "preview/sinkage/compressed",
                                                           [cap](auto& s) { rd::reserve(s, cap, 16, 32); });
  }

  void publish(int i) {
    const std::int64_t stamp = kEpochNs + i * 50 * regolith::kNsPerMs;
    if (auto* s = diag_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::set_length(s->status, 3);
      status(s->status._buffer[0], 0, "rate_group: fast", "ok",
             {{"period_us", "10000.0000"},
              {"cycles", std::to_string(1000 + i)},
              {"cycle_slips", "5"},
              {"late_start_slips", "3"},
              {"stall_slips", "1"},
              {"exec_p99_us", "812.5000"},
              {"wakeup_p99_us", "64.2500"}});
      status(s->status._buffer[1], 1, "component: wheel_sinkage", "input stale",
             {{"heartbeat", std::to_string(500 + i)},
              {"period_us", "50000.0000"},
              {"cycle_slips", "3"},
              {"exec_p99_us", "4100.2500"},
              {"errors", "0"},
              {"stale_inputs", "1"}});
      status(s->status._buffer[2], 2, "camera: front", "no frames",
             {{"frames", "0"}, {"dropped", "12"}, {"faults", "2"}, {"stale_inputs", "1"}});
      done(diag_, "diagnostics", s);
    }
    if (auto* s = sinkage_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "base_link");
      rd::set_length(s->wheel_names, 4);
      rd::set_length(s->sinkage_m, 4);
      rd::set_length(s->confidence, 4);
      const char* wheels[] = {"front_left", "front_right", "rear_left", "rear_right"};
      for (std::uint32_t w = 0; w < 4; ++w) {
        rd::copy_string(s->wheel_names._buffer[w], 32, wheels[w]);
        s->sinkage_m._buffer[w] = 0.012 + 0.004 * w + 0.003 * std::sin(0.15 * i + w);
        s->confidence._buffer[w] = w == 3 ? std::nan("") : 0.9 - 0.1 * w;
      }
      done(sinkage_, "sinkage", s);
    }
    if (auto* s = soil_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "rear_ground");
      s->k = kSoilK;
      s->n = 1.0625;
      s->k_sigma = 23456.7;
      s->n_sigma = 0.042;
      s->mean_sinkage_m = 0.0185;
      s->samples_used = 7;
      rd::copy_string(s->soil_class, 32, "GRC-1 simulant");
      done(soil_, "soil", s);
    }
    if (auto* s = map_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "odom");
      rd::set_length(s->layers, 2);
      rd::set_length(s->basic_layers, 1);
      rd::set_length(s->data, 2);
      rd::copy_string(s->layers._buffer[0], 32, "elevation");
      rd::copy_string(s->layers._buffer[1], 32, "traversability");
      rd::copy_string(s->basic_layers._buffer[0], 32, "elevation");
      s->info.resolution = 0.1;
      s->info.length_x = kRows * 0.1;
      s->info.length_y = kCols * 0.1;
      s->info.pose.position.x = 1.5;
      s->info.pose.position.y = -0.5;
      s->outer_start_index = 3;  // a scrolled circular buffer: the page must start at these
      s->inner_start_index = 5;
      for (std::uint32_t j = 0; j < kCols; ++j) {
        for (std::uint32_t r = 0; r < kRows; ++r) {
          const float x = 0.1f * static_cast<float>(r), y = 0.1f * static_cast<float>(j);
          const bool unseen = r < 4 && j > 30;  // a never-observed corner: NaN
          s->data._buffer[0].data._buffer[j * kRows + r] =
              unseen ? NAN : 0.05f * std::sin(2.0f * x) * std::cos(1.5f * y) + 0.01f * static_cast<float>(i % 3);
          s->data._buffer[1].data._buffer[j * kRows + r] = unseen ? NAN : 0.25f * static_cast<float>((r + j) % 5);
        }
      }
      done(map_, "world_map", s);
    }
    if (auto* s = rocks_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "front_optical");
      rd::set_length(s->detections, 3);
      for (auto* seq : {&s->ground_range_m, &s->lateral_offset_m, &s->width_m, &s->height_m}) rd::set_length(*seq, 3);
      rd::set_length(s->hazard, 3);
      for (std::uint32_t k = 0; k < 3; ++k) {
        auto& d = s->detections._buffer[k];
        rd::set_time(d.header.stamp, stamp);
        rd::copy_string(d.header.frame_id, 32, "front_optical");
        rd::copy_string(d.id, 32, ("rock_" + std::to_string(k + 1)).c_str());
        rd::set_length(d.results, 1);
        rd::copy_string(d.results._buffer[0].hypothesis.class_id, 32, "rock");
        d.results._buffer[0].hypothesis.score = 0.5 + 0.125 * k;
        d.results._buffer[0].pose.covariance[0] = 0.01 * (k + 1);
        d.bbox.center.position.x = 100.0 + 50 * k;
        d.bbox.center.position.y = 200.5;
        d.bbox.size_x = 30.0 + k;
        d.bbox.size_y = 20.0;
        s->ground_range_m._buffer[k] = 2.5 + k;
        s->lateral_offset_m._buffer[k] = -0.75 + 0.5 * k;
        s->width_m._buffer[k] = 0.15 + 0.05 * k;
        s->height_m._buffer[k] = 0.05 + 0.1 * k;
        s->hazard._buffer[k] = k == 2;
      }
      done(rocks_, "rocks", s);
    }
    if (auto* s = world_rocks_->begin()) {
      // Two rocks of the world map, in its frame: one with a correlated covariance.
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "odom");
      rd::set_length(s->detections, 2);
      for (std::uint32_t k = 0; k < 2; ++k) {
        auto& d = s->detections._buffer[k];
        rd::set_time(d.header.stamp, stamp);
        rd::copy_string(d.header.frame_id, 32, "odom");
        rd::copy_string(d.results._buffer[0].hypothesis.class_id, 32, "rock");
        auto& h = d.results._buffer[0];
        h.hypothesis.score = 0.75 + 0.125 * k;
        h.pose.pose.position.x = 2.0 + 0.5 * k;
        h.pose.pose.position.y = -0.5 - 0.75 * k;
        h.pose.pose.position.z = 0.1;
        for (double& c : h.pose.covariance) c = 0.0;
        h.pose.covariance[0] = 0.04;
        h.pose.covariance[1] = h.pose.covariance[6] = k == 0 ? 0.0 : 0.015;
        h.pose.covariance[7] = 0.01;
        h.pose.covariance[14] = 0.0025;
        h.pose.covariance[21] = h.pose.covariance[28] = h.pose.covariance[35] = 1e6;
        d.bbox.center = h.pose.pose;
        d.bbox.size.x = d.bbox.size.y = 0.3 + 0.1 * k;
        d.bbox.size.z = 0.2;
      }
      done(world_rocks_, "world_rocks", s);
    }
    if (auto* s = odom_->begin()) {
      rd::set_time(s->header.stamp, stamp);
      rd::copy_string(s->header.frame_id, 32, "odom");
      rd::copy_string(s->child_frame_id, 32, "base_link");
      const double a = 0.05 * i;
      s->pose.pose.position.x = 1.5 + 0.8 * std::sin(a);
      s->pose.pose.position.y = -0.5 + 0.8 * (1.0 - std::cos(a));
      s->pose.pose.orientation.z = std::sin(0.5 * a);
      s->pose.pose.orientation.w = std::cos(0.5 * a);
      for (int k = 0; k < 36; ++k) s->pose.covariance[k] = k % 7 == 0 ? 0.001 * (k + 1) : 0.0;
      s->twist.twist.linear.x = 0.04;
      s->twist.twist.angular.z = 0.05;
      done(odom_, "odom", s);
    }
    for (auto* box : {&preview_, &wheel_preview_}) {
      if (auto* s = (*box)->begin()) {
        rd::set_time(s->header.stamp, stamp);
        rd::copy_string(s->header.frame_id, 32, "front_optical_frame");
        rd::copy_string(s->format, 16, "jpeg");
        rd::set_length(s->data, jpeg_.size());
        std::copy(jpeg_.begin(), jpeg_.end(), s->data._buffer);
        done(*box, box == &preview_ ? "rocks_preview" : "sinkage_preview", s);
      }
    }
  }

  std::map<std::string, json> last;  // key -> to_json of its last sample

 private:
  template <class Msg>
  static std::shared_ptr<rd::Outbox<Msg>> make(rd::Participant& p, const char* topic,
                                               const std::function<void(Msg&)>& reserve) {
    return p.make_outbox<Msg>(topic, rd::find_topic(topic)->writer_qos(), {.mode = rd::OutboxMode::kFifo, .slots = 8},
                              reserve);
  }
  template <class Box, class Msg>
  void done(Box& box, const std::string& key, Msg* s) {
    last[key] = rd::to_json(*s);
    box->commit();
  }
  static void status(m::diagnostic_msgs::DiagnosticStatus& st, std::uint8_t level, const char* name,
                     const char* message, const std::vector<std::pair<std::string, std::string>>& values) {
    st.level = level;
    rd::copy_string(st.name, 64, name);
    rd::copy_string(st.message, 64, message);
    rd::copy_string(st.hardware_id, 64, "fake_rover");
    rd::set_length(st.values, values.size());
    for (std::size_t k = 0; k < values.size(); ++k) {
      rd::copy_string(st.values._buffer[k].key, 64, values[k].first);
      rd::copy_string(st.values._buffer[k].value, 64, values[k].second);
    }
  }

  std::shared_ptr<rd::Outbox<m::diagnostic_msgs::DiagnosticArray>> diag_;
  std::shared_ptr<rd::Outbox<m::regolith_msgs::WheelSinkage>> sinkage_;
  std::shared_ptr<rd::Outbox<m::regolith_msgs::SoilStiffness>> soil_;
  std::shared_ptr<rd::Outbox<m::grid_map_msgs::GridMap>> map_;
  std::shared_ptr<rd::Outbox<m::regolith_msgs::RockArray>> rocks_;
  std::shared_ptr<rd::Outbox<m::vision_msgs::Detection3DArray>> world_rocks_;
  std::shared_ptr<rd::Outbox<m::nav_msgs::Odometry>> odom_;
  std::shared_ptr<rd::Outbox<m::sensor_msgs::CompressedImage>> preview_, wheel_preview_;
  std::vector<std::uint8_t> jpeg_;
};

/// The fake rover publishing in one participant and a DdsRelay serving the page from another.
struct LiveRig {
  explicit LiveRig(const std::string& web_root)
      : ns(rd::testing::unique_ns()), pub(config(ns)), sub(config(ns)), rover(pub), relay(sub, options(web_root)) {
    pub.start();
    relay.start();
  }
  ~LiveRig() {
    stop_publishing();
    relay.stop();
    pub.stop();
  }
  /// Publishes cycle i, i + 1, ... every 50 ms on a thread of its own until stop_publishing().
  void keep_publishing() {
    publisher = std::thread([this] {
      for (int i = 0; !stop.load(); ++i) {
        rover.publish(i);
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    });
  }
  void stop_publishing() {
    stop.store(true);
    if (publisher.joinable()) publisher.join();
  }
  static rd::ParticipantConfig config(const std::string& ns) {
    rd::testing::use_loopback_config();
    return {rd::testing::test_domain(), ns};
  }

  std::string ns;
  rd::Participant pub, sub;
  FakeRover rover;
  rl::DdsRelay relay;
  std::atomic<bool> stop{false};
  std::thread publisher;
};

/// Headless chromium driven over its DevTools protocol (a WebSocket of its own, spoken with the
/// test client): the page is inspected in real time, as it fills with live data (a virtual-time
/// budget would end before the streams arrive).
class Chromium {
 public:
  Chromium(const fs::path& exe, const fs::path& dir, const std::string& url) {
    const fs::path profile = dir / "profile";
    pid_ = rt::spawn(
        {exe.string(), "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run", "--disable-dev-shm-usage",
         "--user-data-dir=" + profile.string(), "--window-size=1280,900", "--remote-debugging-port=0", url},
        dir / "chromium.log", {rt::Stderr::kBeside, /*own_process_group=*/true});
    if (pid_ <= 0) return;
    std::uint16_t port = 0;
    until(
        [&] {
          std::ifstream in(profile / "DevToolsActivePort");
          return static_cast<bool>(in >> port);
        },
        std::chrono::seconds(30));
    if (port == 0) return;
    // The page's target, once it exists.
    std::string target;
    until(
        [&] {
          const json list = json::parse(http(port, "/json/list").body, nullptr, false);
          if (!list.is_array()) return false;
          for (const json& t : list) {
            if (t.value("type", "") == "page") target = t.value("webSocketDebuggerUrl", "");
          }
          return !target.empty();
        },
        std::chrono::seconds(30));
    const auto path = target.find("/devtools/");
    if (path == std::string::npos) return;
    client_ = std::make_unique<WsClient>(port, "", 0, target.substr(path));
  }
  ~Chromium() { close(); }
  Chromium(const Chromium&) = delete;
  Chromium& operator=(const Chromium&) = delete;

  bool ok() const { return client_ && client_->ok(); }

  /// Ends chromium (idempotent).
  void close() {
    client_.reset();
    if (pid_ > 0) {
      rt::kill_group(pid_, std::chrono::seconds(10));
      pid_ = -1;
    }
  }

  /// The value of a JavaScript expression in the page (null when it fails).
  json evaluate(const std::string& expression) {
    const json r = call("Runtime.evaluate", {{"expression", expression}, {"returnByValue", true}});
    return r.contains("exceptionDetails") ? json() : r.value("/result/value"_json_pointer, json());
  }
  /// The viewport as PNG bytes.
  std::string screenshot() {
    return base64_decode(call("Page.captureScreenshot", {{"format", "png"}}).value("data", ""));
  }

 private:
  json call(const std::string& method, const json& params) {
    const int id = ++next_id_;
    if (!client_->send_text(json{{"id", id}, {"method", method}, {"params", params}}.dump())) return json::object();
    while (auto f = client_->read(30000)) {
      const json j = json::parse(f->payload, nullptr, false);
      if (j.is_object() && j.value("id", -1) == id) return j.value("result", json::object());
    }
    return json::object();
  }
  static std::string base64_decode(const std::string& in) {
    std::string out;
    int bits = 0, value = 0;
    for (char ch : in) {
      const char* alphabet = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
      const char* at = std::strchr(alphabet, ch);
      if (ch == '=' || ch == '\0' || at == nullptr) break;
      value = (value << 6) | static_cast<int>(at - alphabet);
      bits += 6;
      if (bits >= 8) {
        bits -= 8;
        out.push_back(static_cast<char>((value >> bits) & 0xff));
      }
    }
    return out;
  }

  pid_t pid_ = -1;
  std::unique_ptr<WsClient> client_;
  int next_id_ = 0;
};

}  // namespace

TEST(LivePage, ServesThePageFilesOnTheWebSocketPort) {
  rl::FoxgloveServer server(one_channel(), options(REGOLITH_LIVE_WEB_DIR));
  server.start();
  const std::uint16_t port = server.port();

  const HttpReply index = http(port, "/");
  EXPECT_EQ(index.status, 200);
  EXPECT_EQ(index.content_type, "text/html; charset=utf-8");
  EXPECT_NE(index.body.find("<title>regolith live</title>"), std::string::npos);
  EXPECT_EQ(http(port, "/index.html?x=1").body, index.body);
  for (const char* js : {"/app.js", "/cdr.js"}) {
    const HttpReply r = http(port, js);
    EXPECT_EQ(r.status, 200) << js;
    EXPECT_EQ(r.content_type, "text/javascript; charset=utf-8") << js;
    EXPECT_EQ(r.body, rt::read_file(fs::path(REGOLITH_LIVE_WEB_DIR) / (js + 1))) << js;
  }
  EXPECT_EQ(http(port, "/style.css").content_type, "text/css; charset=utf-8");

  // Nothing outside the web root, nothing unknown, however spelled.
  for (const char* bad : {"/../etc/passwd", "/nope", "/nope.js", "/..%2f..%2fetc%2fpasswd", "/%2e%2e/etc/passwd",
                          "//etc/passwd", "/./index.html", "/.hidden.js", "/web/../index.html", "/../web/index.html",
                          "index.html", "http://127.0.0.1/../etc/passwd"}) {
    const HttpReply r = http(port, bad);
    EXPECT_EQ(r.status, 404) << bad;
    EXPECT_EQ(r.body.find("root:"), std::string::npos) << bad;
  }
  EXPECT_EQ(http(port, "/", "POST").status, 405);

  // The same port still speaks the protocol.
  WsClient c(port, rl::kSubprotocol);
  ASSERT_TRUE(c.ok()) << c.response();
  EXPECT_EQ(read_json(c).value("op", ""), "serverInfo");
  EXPECT_EQ(read_json(c).value("op", ""), "advertise");
}

TEST(LivePage, WithoutAWebRootAnswers404AndTheProtocolStillWorks) {
  rl::FoxgloveServer server(one_channel(), options(""));
  server.start();
  const HttpReply r = http(server.port(), "/");
  EXPECT_EQ(r.status, 404);
  EXPECT_NE(r.body.find("not installed"), std::string::npos) << r.body;
  EXPECT_EQ(http(server.port(), "/app.js").status, 404);

  WsClient c(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(c.ok()) << c.response();
  EXPECT_EQ(read_json(c).value("op", ""), "serverInfo");
  EXPECT_EQ(read_json(c).value("op", ""), "advertise");
  ASSERT_TRUE(c.send_text(R"({"op":"subscribe","subscriptions":[{"id":9,"channelId":3}]})"));
  ASSERT_TRUE(rd::testing::eventually([&] { return server.has_subscribers(3); }));
  const std::uint8_t payload[] = {0, 1, 0, 0, 42};
  server.send_message(3, 77, payload, sizeof payload);
  const auto f = c.read();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->opcode, 2);
  ASSERT_EQ(f->payload.size(), 1u + 4 + 8 + sizeof payload);
  EXPECT_EQ(f->payload[1], 9);
  EXPECT_EQ(f->payload.back(), 42);
}

TEST(LivePage, ATokenGuardsThePageAndTheProtocolOffLoopback) {
  const regolith::testing::TempDir tmp("live_page_token");  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const fs::path file = dir / "live.token";
  auto write = [&](const std::string& text, fs::perms perms) {
    std::ofstream(file, std::ios::trunc) << text;
    fs::permissions(file, perms, fs::perm_options::replace);
  };
  const fs::perms owner = fs::perms::owner_read | fs::perms::owner_write;
  write("s3cret-Token_42\n", owner);
  const std::string token = rl::read_token_file(file.string());
  EXPECT_EQ(token, "s3cret-Token_42");
  // A token file anyone else can read, an empty one, two words, none at all: refused, named.
  auto refused = [&](const std::string& containing) {
    try {
      rl::read_token_file(file.string());
      ADD_FAILURE() << "accepted; expected: " << containing;
    } catch (const std::invalid_argument& e) {
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(containing), std::string::npos) << e.what();
    }
  };
  write("s3cret", owner | fs::perms::group_read | fs::perms::others_read);
  refused("chmod 600");
  write(" \n", owner);
  refused("empty");
  write("two words", owner);
  refused("one word");
  fs::remove(file);
  refused("cannot read");

  // Every interface without a token: refused before anything listens.
  rl::FoxgloveServerOptions open = options(REGOLITH_LIVE_WEB_DIR);
  open.address = "0.0.0.0";
  try {
    rl::FoxgloveServer s(one_channel(), open);
    ADD_FAILURE() << "a non-loopback server without a token started";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("needs an access token"), std::string::npos) << e.what();
  }
  EXPECT_TRUE(rl::is_loopback_address("127.0.0.1"));
  EXPECT_TRUE(rl::is_loopback_address("::1"));
  EXPECT_FALSE(rl::is_loopback_address("0.0.0.0"));
  EXPECT_FALSE(rl::is_loopback_address("192.168.1.20"));

  // With a token every request needs it: in the URL, as a bearer header, or as the cookie the
  // first good request sets (the page's files and its WebSocket then follow on their own).
  rl::FoxgloveServerOptions guarded = options(REGOLITH_LIVE_WEB_DIR);
  guarded.token = token;
  rl::FoxgloveServer server(one_channel(), guarded);
  server.start();
  const std::uint16_t port = server.port();
  const HttpReply none = http(port, "/");
  EXPECT_EQ(none.status, 401);
  EXPECT_NE(none.body.find("token"), std::string::npos) << none.body;
  EXPECT_EQ(none.body.find("<title>"), std::string::npos);
  EXPECT_EQ(http(port, "/?token=s3cret-Token_41").status, 401);
  EXPECT_EQ(http(port, "/app.js", "GET", "Authorization: Bearer nope\r\n").status, 401);
  const HttpReply good = http(port, "/?token=s3cret-Token_42");
  EXPECT_EQ(good.status, 200);
  EXPECT_NE(good.body.find("<title>regolith live</title>"), std::string::npos);
  const std::string cookie = header(good.head, "set-cookie");
  EXPECT_EQ(cookie.rfind("regolith_token=s3cret-Token_42;", 0), 0u) << cookie;
  EXPECT_NE(cookie.find("HttpOnly"), std::string::npos) << cookie;
  EXPECT_EQ(http(port, "/app.js", "GET", "Cookie: theme=dark; regolith_token=s3cret-Token_42\r\n").status, 200);
  EXPECT_EQ(http(port, "/app.js", "GET", "Authorization: Bearer s3cret-Token_42\r\n").status, 200);
  EXPECT_EQ(http(port, "/app.js?token=s3cret%2DToken_42").status, 200);  // percent-encoded, as the page sends it
  {
    WsClient anonymous(port, rl::kSubprotocol);
    EXPECT_FALSE(anonymous.ok());
    EXPECT_EQ(anonymous.response().rfind("HTTP/1.1 401", 0), 0u) << anonymous.response();
  }
  WsClient c(port, rl::kSubprotocol, 0, "/?token=s3cret-Token_42");
  ASSERT_TRUE(c.ok()) << c.response();
  EXPECT_EQ(read_json(c).value("op", ""), "serverInfo");
  const auto st = server.stats();
  EXPECT_EQ(st.unauthorized, 4u);
  EXPECT_EQ(st.accepted, 1u);
}

TEST(LivePage, DefaultWebRootHasThePage) {
  const std::string root = rl::default_web_root();
  ASSERT_FALSE(root.empty());
  for (const char* f : {"index.html", "app.js", "cdr.js", "style.css"})
    EXPECT_TRUE(fs::exists(fs::path(root) / f)) << f;
}

// The relay reports its own counters on /diagnostics once a second, beside the rover's health
// component: what a rover team sees in the page's health table or `regolith echo /diagnostics`.
TEST(LivePage, TheServerReportsItsClientsOnDiagnostics) {
  LiveRig rig("");
  WsClient c(rig.relay.server().port(), rl::kSubprotocol);
  ASSERT_TRUE(c.ok()) << c.response();
  json found;
  std::ostringstream out;
  // The report of a second taken before the client was accepted says 0 clients: wait for the first
  // report that counts it (once a second).
  const auto counts_the_client = [](const json& s) {
    for (const json& v : s.value("values", json::array()))
      if (v.value("key", "") == "accepted") return v.value("value", "") != "0";
    return false;
  };
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (found.is_null() && std::chrono::steady_clock::now() < end) {
    out.str("");
    rd::echo(rig.pub, "/diagnostics", {.count = 1, .timeout_ns = 3 * regolith::kNsPerSec}, out);
    std::istringstream lines(out.str());
    for (std::string line; std::getline(lines, line);) {
      const json j = json::parse(line, nullptr, false);
      if (!j.is_object()) continue;
      for (const json& s : j.value("status", json::array()))
        if (s.value("name", "") == "live: foxglove server" && counts_the_client(s)) found = s;
    }
  }
  ASSERT_FALSE(found.is_null()) << out.str();
  std::map<std::string, std::string> kv;
  for (const json& v : found.at("values")) kv[v.at("key")] = v.at("value");
  EXPECT_EQ(kv.at("connected"), "1");
  EXPECT_EQ(kv.at("accepted"), "1");
  EXPECT_EQ(kv.at("dropped_slow"), "0");
  EXPECT_EQ(found.at("level"), 0);
  EXPECT_EQ(found.at("hardware_id"), "ws://127.0.0.1:" + std::to_string(rig.relay.server().port()));
}

// Under --sim-time the relay shares the run's participant, whose source clock is the simulated
// ROS time: the server's own report is stamped on that time line too, like every other sample.
TEST(LivePage, TheServerReportIsStampedWithTheParticipantsRosTime) {
  const std::string ns = rd::testing::unique_ns();
  rd::Participant relayed(LiveRig::config(ns)), reader(LiveRig::config(ns));
  constexpr regolith::TimeNs kSimulated = 1234 * regolith::kNsPerSec + 500 * regolith::kNsPerMs;
  relayed.set_source_clock([] { return kSimulated; });
  rl::DdsRelay relay(relayed, options(""));
  relay.start();
  std::ostringstream out;
  rd::echo(reader, "/diagnostics", {.count = 1, .timeout_ns = 5 * regolith::kNsPerSec}, out);
  relay.stop();
  const json j = json::parse(out.str().substr(0, out.str().find('\n')), nullptr, false);
  ASSERT_TRUE(j.is_object()) << out.str();
  EXPECT_EQ(j["header"]["stamp"]["sec"], 1234) << out.str();
  EXPECT_EQ(j["header"]["stamp"]["nanosec"], 500000000) << out.str();
}

#ifdef REGOLITH_NODE
// cdr.js decodes what Cyclone DDS serialized: each topic's relayed messageData frame is written
// to a file with the sample as the runtime renders it (dds::to_json); node decodes the frame with
// the page's module and compares every field exactly (tests/live/js/cdr_check.mjs).
TEST(LivePage, CdrModuleDecodesRelayedSamplesExactly) {
  LiveRig rig("");
  const regolith::testing::TempDir tmp("live_page_" + rig.ns);  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  const std::map<std::string, std::string> topics = {{"diagnostics", "/diagnostics"},
                                                     {"sinkage", "/" + rig.ns + "/terrain/wheel_sinkage"},
                                                     {"soil", "/" + rig.ns + "/terrain/soil"},
                                                     {"world_map", "/" + rig.ns + "/terrain/world_map"},
                                                     {"rocks", "/" + rig.ns + "/terrain/rocks"},
                                                     {"world_rocks", "/" + rig.ns + "/terrain/world_rocks"},
                                                     {"odom", "/" + rig.ns + "/odom"},
                                                     {"rocks_preview", "/" + rig.ns + "/preview/rocks/compressed"}};

  WsClient c(rig.relay.server().port(), rl::kSubprotocol);
  ASSERT_TRUE(c.ok()) << c.response();
  read_json(c);  // serverInfo
  const json adv = read_json(c);
  std::map<std::uint32_t, std::pair<std::string, std::string>> by_channel;  // id -> key, schema
  json subs = json::array();
  for (const json& ch : adv.at("channels")) {
    for (const auto& [key, topic] : topics) {
      if (ch.at("topic") == topic) {
        by_channel[ch.at("id").get<std::uint32_t>()] = {key, ch.at("schemaName").get<std::string>()};
        subs.push_back({{"id", 100 + ch.at("id").get<int>()}, {"channelId", ch.at("id")}});
      }
    }
  }
  ASSERT_EQ(by_channel.size(), topics.size());
  ASSERT_TRUE(c.send_text(json{{"op", "subscribe"}, {"subscriptions", subs}}.dump()));
  ASSERT_TRUE(rd::testing::eventually([&] {
    for (const auto& [id, _] : by_channel)
      if (!rig.relay.server().has_subscribers(id)) return false;
    return true;
  }));

  // Cycle 0 over and over: every sample of a topic is the same, whichever one is relayed.
  std::map<std::string, std::string> frames;
  const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(30);
  while (frames.size() < topics.size() && std::chrono::steady_clock::now() < end) {
    rig.rover.publish(0);
    while (auto f = c.read(50)) {
      if (f->opcode != 2 || f->payload.size() < 13) continue;
      std::uint32_t sub = 0;
      for (int b = 3; b >= 0; --b)
        sub = (sub << 8) | static_cast<unsigned char>(f->payload[1 + static_cast<std::size_t>(b)]);
      const auto it = by_channel.find(sub - 100);
      // /diagnostics also carries the relay's own status (its own publisher): not the fake rover's
      if (it != by_channel.end() && f->payload.find("live: foxglove server") == std::string::npos)
        frames.emplace(it->second.first, f->payload);
    }
  }
  ASSERT_EQ(frames.size(), topics.size());
  for (const auto& [id, ks] : by_channel) {
    const auto& [key, schema] = ks;
    std::ofstream(dir / (key + ".frame"), std::ios::binary) << frames.at(key);
    std::ofstream(dir / (key + ".json")) << json{
        {"schemaName", schema},
        {"subscriptionId", 100 + id},
        {"message", rig.rover.last.at(key)}}.dump();
  }

  const fs::path log = dir / "cdr_check.log";
  const pid_t pid = rt::spawn({REGOLITH_NODE, REGOLITH_LIVE_JS_DIR "/cdr_check.mjs", REGOLITH_LIVE_WEB_DIR "/cdr.js",
                               dir.string(), std::to_string(topics.size())},
                              log, {rt::Stderr::kBeside, /*own_process_group=*/true});
  ASSERT_GT(pid, 0);
  const bool ok = rt::wait_exit(pid, std::chrono::seconds(60)) == 0;
  std::printf("%s", rt::read_file(log).c_str());
  EXPECT_TRUE(ok) << rt::read_file(log.string() + ".err");
}
#endif

// The page in a real browser against the fake rover. Debian's chromium is not a build dependency:
// skipped (with the reason) when /usr/bin/chromium is absent.
TEST(LivePage, ChromiumShowsThePanelsFilled) {
  const fs::path chromium = "/usr/bin/chromium";
  if (!fs::exists(chromium))
    GTEST_SKIP() << "/usr/bin/chromium not installed (apt-get install chromium): page not rendered";
  LiveRig rig(REGOLITH_LIVE_WEB_DIR);
  rig.keep_publishing();
  const regolith::testing::TempDir tmp("live_page_" + rig.ns);  // removed whatever the outcome
  const fs::path& dir = tmp.path();
  Chromium browser(chromium, dir, "http://127.0.0.1:" + std::to_string(rig.relay.server().port()) + "/");
  ASSERT_TRUE(browser.ok()) << rt::read_file(dir / "chromium.log.err");

  // Every panel filled: the page's waiting lines all hidden (a real-time wait: the data is live).
  const bool filled = until(
      [&] {
        return browser.evaluate(
                   "document.querySelector('.waiting') !== null && "
                   "document.querySelector('.waiting:not([hidden])') === null") == true;
      },
      std::chrono::seconds(30));
  const json dom = browser.evaluate("document.documentElement.outerHTML");
  const std::string html = dom.is_string() ? dom.get<std::string>() : std::string();
  ASSERT_TRUE(filled) << html;
  EXPECT_NE(html.find(R"(<tr class="ok" data-name="rate_group: fast">)"), std::string::npos) << html;
  // a count that does not grow is history, not news (the row stays "ok"); the late starts and
  // stalls beside it
  EXPECT_NE(html.find(R"(<td class="num bad">5 (3 late, 1 stalled)</td>)"), std::string::npos) << html;
  EXPECT_EQ(html.find("late_start_slips"), std::string::npos) << "shown in the slips cell, not again among the rest";
  EXPECT_EQ(html.find("stall_slips"), std::string::npos) << "shown in the slips cell, not again among the rest";
  EXPECT_NE(html.find(R"(<tr class="warn" data-name="component: wheel_sinkage">)"), std::string::npos);
  EXPECT_NE(html.find(R"(<tr class="error" data-name="camera: front">)"), std::string::npos);
  EXPECT_NE(html.find(R"(<b id="soil-k">812.3</b>)"), std::string::npos);
  EXPECT_NE(html.find(R"(<div class="soil-class" id="soil-class">GRC-1 simulant</div>)"), std::string::npos);
  EXPECT_NE(html.find(R"(<tr class="error"><td>rock_3</td>)"), std::string::npos);
  EXPECT_NE(html.find(">front_left</td>"), std::string::npos);
  EXPECT_NE(html.find("40×30 cells of 0.10 m"), std::string::npos);
  // the map's rocks (terrain/world_rocks, in the map's frame) drawn on it
  EXPECT_NE(html.find("2 rocks from /" + rig.ns + "/terrain/world_rocks: footprint filled, 95 % position ellipse"),
            std::string::npos)
      << html;
  // both camera previews decoded and shown (the image's own size, from the JPEG; decoding is
  // asynchronous, after the message arrived)
  const bool shown = until(
      [&] {
        return browser.evaluate(
                   "['rocksPreview', 'sinkagePreview'].every((k) => "
                   "Number(document.getElementById(k + '-image').dataset.frames ?? 0) > 0)") == true;
      },
      std::chrono::seconds(30));
  EXPECT_TRUE(shown);
  // the decoded size as the page recorded it on load (naturalWidth itself is 0 whenever the next
  // preview is loading, which made this check fail under load)
  EXPECT_EQ(browser.evaluate("document.getElementById('rocksPreview-image').dataset.width"), "160");
  EXPECT_EQ(browser.evaluate("document.getElementById('sinkagePreview-image').hidden"), false);
  const json info = browser.evaluate("document.getElementById('rocksPreview-info').textContent");
  EXPECT_NE(info.dump().find("160×120 · "), std::string::npos) << info;
  EXPECT_NE(html.find(R"(<div id="problem" class="problem"></div>)"), std::string::npos) << "a decoding problem shown";

  // Let the sinkage plot gather a few points, then the screenshot must not be blank.
  std::this_thread::sleep_for(std::chrono::seconds(2));
  browser.evaluate("document.getElementById('map-canvas').scrollIntoView()");
  std::ofstream(fs::path(REGOLITH_BINARY_DIR) / "tests" / "live" / "live_page_map.png", std::ios::binary)
      << browser.screenshot();  // the map panel, for a human look
  browser.evaluate("window.scrollTo(0, 0)");
  const std::string png = browser.screenshot();
  const fs::path shot = fs::path(REGOLITH_BINARY_DIR) / "tests" / "live" / "live_page.png";  // for a human look
  std::ofstream(shot, std::ios::binary) << png;
  const cv::Mat img = cv::imdecode(std::vector<std::uint8_t>(png.begin(), png.end()), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 1280);
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  EXPECT_GT(sd[0] + sd[1] + sd[2], 30.0) << "blank screenshot " << shot;
  std::printf("screenshot: %s\n", shot.c_str());
  browser.close();  // before its profile (tens of MB) is removed with `tmp`
}
