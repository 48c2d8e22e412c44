#include "regolith/live/dds_relay.hpp"

#include <chrono>
#include <string>

#include <time.h>

#include "regolith/dds/outbox.hpp"
#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/serialized.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/msgs/ros2msg.hpp"

namespace regolith::live {
namespace {

using DiagnosticArray = msgs::diagnostic_msgs::DiagnosticArray;
constexpr std::uint32_t kStatusValues = 9;
constexpr std::size_t kStatusString = 64;

}  // namespace

struct DdsRelay::Topic {
  std::uint32_t channel = 0;
  std::unique_ptr<dds::Subscription> sub;
};

DdsRelay::DdsRelay(dds::Participant& p, FoxgloveServerOptions options) : participant_(p) {
  const dds::TopicInfo* diag = dds::find_topic("/diagnostics");
  status_ = p.make_outbox<DiagnosticArray>(
      "/diagnostics", diag->writer_qos(), {.mode = dds::OutboxMode::kLatest, .slots = 2}, [](DiagnosticArray& m) {
        dds::reserve(m, dds::DiagnosticArrayCapacity{1, kStatusValues, kStatusString, 32});
      });
  waitset_ = std::make_unique<dds::ReaderWaitSet>(p.handle());
  std::vector<Channel> channels;
  std::uint32_t id = 1;
  for (const dds::TopicInfo& t : dds::known_topics()) {
    Channel c;
    c.id = id++;
    c.topic = p.ros_name(t.name);
    c.encoding = "cdr";
    c.schema_name = std::string(t.ros_type);
    c.schema = msgs::ros2msg_definition(t.ros_type);
    c.schema_encoding = "ros2msg";
    c.latched = t.cls == dds::TopicClass::kState;  // transient-local: a late subscriber gets the last one
    auto topic = std::make_unique<Topic>();
    topic->channel = c.id;
    topic->sub = std::make_unique<dds::Subscription>(p, t.name, t.descriptor, t.reader_qos());
    waitset_->attach(topic->sub->reader(), c.topic);
    topics_.push_back(std::move(topic));
    channels.push_back(std::move(c));
  }
  const std::string address = options.address;
  server_ = std::make_unique<FoxgloveServer>(std::move(channels), std::move(options));
  where_ = "ws://" + address + ":" + std::to_string(server_->port());
}

DdsRelay::~DdsRelay() {
  stop();
}

void DdsRelay::start() {
  server_->start();
  if (thread_.joinable()) return;
  stop_.store(false);
  thread_ = std::thread([this] { loop(); });
}

void DdsRelay::stop() {
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  server_->stop();
}

void DdsRelay::publish_status() {
  auto& box = static_cast<dds::Outbox<DiagnosticArray>&>(*status_);
  DiagnosticArray* m = box.begin();
  if (m == nullptr) return;
  const FoxgloveServerStats s = server_->stats();
  const bool grew = s.dropped_slow > last_.dropped_slow || s.samples_dropped > last_.samples_dropped ||
                    s.refused > last_.refused || s.unauthorized > last_.unauthorized;
  last_ = s;
  dds::set_time(m->header.stamp, participant_.ros_now());  // the run's ROS time (simulated under --sim-time)
  dds::set_length(m->status, 1);
  auto& st = m->status._buffer[0];
  st.level = grew ? 1 : 0;  // WARN while clients are being dropped or refused
  dds::copy_string(st.name, kStatusString, "live: foxglove server");
  dds::copy_string(st.message, kStatusString,
                   grew ? "clients dropped or refused" : std::to_string(s.connected) + " client(s) connected");
  dds::copy_string(st.hardware_id, kStatusString, where_);
  const std::pair<const char*, std::uint64_t> values[kStatusValues] = {{"connected", s.connected},
                                                                       {"accepted", s.accepted},
                                                                       {"refused", s.refused},
                                                                       {"dropped_slow", s.dropped_slow},
                                                                       {"samples_dropped", s.samples_dropped},
                                                                       {"unauthorized", s.unauthorized},
                                                                       {"bad_requests", s.bad_requests},
                                                                       {"messages_sent", s.messages_sent},
                                                                       {"samples_taken", samples_.load()}};
  dds::set_length(st.values, kStatusValues);
  for (std::uint32_t k = 0; k < kStatusValues; ++k) {
    dds::copy_string(st.values._buffer[k].key, kStatusString, values[k].first);
    dds::copy_string(st.values._buffer[k].value, kStatusString, std::to_string(values[k].second));
  }
  box.commit();
  // `regolith live`'s own participant has no publisher thread
  if (!participant_.running()) box.flush(participant_.source_clock());
}

void DdsRelay::loop() {
  std::vector<std::uint8_t> scratch;
  auto next_status = std::chrono::steady_clock::now();
  while (!stop_.load()) {
    if (std::chrono::steady_clock::now() >= next_status) {
      publish_status();
      next_status += std::chrono::seconds(1);
    }
    if (!waitset_->wait(100 * kNsPerMs)) continue;
    for (auto& t : topics_) {
      try {
        // Taken even without subscribers: the reader's history must not fill with stale samples.
        const std::size_t n = dds::take_serialized(
            t->sub->reader(),
            [&](std::span<const std::uint8_t> bytes, const dds_sample_info_t& info) {
              // The time line of the sample's header stamps (wall or simulated time).
              server_->send_message(t->channel, dds::source_time_or(info, dds::receipt_time_ns()), bytes);
            },
            scratch, 256);
        samples_.fetch_add(n);
      } catch (const std::exception&) {  // a DDS error on one topic must not end the relay
      }
    }
  }
}

}  // namespace regolith::live
