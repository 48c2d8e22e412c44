#include "regolith/live/dds_relay.hpp"

#include <time.h>

#include <string>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/serialized.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/msgs/ros2msg.hpp"

namespace regolith::live {
namespace {

std::uint64_t realtime_ns() { return static_cast<std::uint64_t>(realtime_now()); }

}  // namespace

struct DdsRelay::Topic {
  std::uint32_t channel = 0;
  std::unique_ptr<dds::Subscription> sub;
};

DdsRelay::DdsRelay(dds::Participant& p, FoxgloveServerOptions options) {
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
  server_ = std::make_unique<FoxgloveServer>(std::move(channels), std::move(options));
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

void DdsRelay::loop() {
  std::vector<std::uint8_t> scratch;
  while (!stop_.load()) {
    if (!waitset_->wait(100 * kNsPerMs)) continue;
    for (auto& t : topics_) {
      try {
        // Taken even without subscribers: the reader's history must not fill with stale samples.
        const std::size_t n = dds::take_serialized(
            t->sub->reader(),
            [&](std::span<const std::uint8_t> bytes, const dds_sample_info_t&) {
              server_->send_message(t->channel, realtime_ns(), bytes);
            },
            scratch, 256);
        samples_.fetch_add(n);
      } catch (const std::exception&) {  // a DDS error on one topic must not end the relay
      }
    }
  }
}

}  // namespace regolith::live
