#include "regolith/dds/recorder.hpp"

#include <algorithm>

#include <time.h>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/reader.hpp"
#include "regolith/dds/serialized.hpp"
#include "regolith/msgs/ros2msg.hpp"
#include "regolith/record/cdr.hpp"

namespace regolith::dds {
namespace {

/// A QoS duration in rosbag2's YAML ({sec, nsec}); 0 = infinite, written as ROS 2 Humble writes
/// RMW_DURATION_INFINITE.
std::string yaml_duration(const char* key, TimeNs ns) {
  const long long sec = ns > 0 ? ns / kNsPerSec : 2147483647LL;
  const long long nsec = ns > 0 ? ns % kNsPerSec : 4294967295LL;
  return std::string("  ") + key + ":\n    sec: " + std::to_string(sec) + "\n    nsec: " + std::to_string(nsec) + "\n";
}

}  // namespace

std::uint64_t sim_log_time(std::uint64_t source_ns, std::int64_t clock_ns, std::uint64_t receipt_ns) {
  if (clock_ns < 0) return source_ns;
  const auto clock = static_cast<std::uint64_t>(clock_ns);
  const auto distance = [](std::uint64_t a, std::uint64_t b) { return a > b ? a - b : b - a; };
  return distance(source_ns, clock) <= distance(source_ns, receipt_ns) ? source_ns : clock;
}

// Enum values of rmw: history 1 keep_last / 2 keep_all; reliability 1 reliable / 2 best_effort;
// durability 1 transient_local / 2 volatile; liveliness 1 automatic.
std::string offered_qos_yaml(const QosProfile& q) {
  std::string y = "- history: " + std::string(q.keep_all ? "2" : "1") + "\n";
  y += "  depth: " + std::to_string(q.keep_all ? 0 : q.depth) + "\n";
  y += "  reliability: " + std::string(q.reliability == Reliability::kReliable ? "1" : "2") + "\n";
  y += "  durability: " + std::string(q.durability == Durability::kTransientLocal ? "1" : "2") + "\n";
  y += yaml_duration("deadline", q.deadline_ns);
  y += yaml_duration("lifespan", 0);
  y += "  liveliness: 1\n";
  y += yaml_duration("liveliness_lease_duration", 0);
  y += "  avoid_ros_namespace_conventions: false";
  return y;
}

struct DdsRecorder::Recorded {
  const TopicInfo* info = nullptr;
  std::string ros_name;
  std::unique_ptr<Subscription> sub;
  std::uint16_t channel = 0;
  std::uint32_t sequence = 0;
  std::atomic<std::uint64_t> count{0};
};

DdsRecorder::DdsRecorder(Participant& p, const std::filesystem::path& file, DdsRecorderOptions options)
    : path_(file), opts_(std::move(options)) {
  if (opts_.topics.empty()) {
    for (const auto& t : known_topics()) opts_.topics.push_back(&t);
  }
  record::McapWriterOptions wo;
  wo.compression = opts_.compression;
  wo.library = opts_.library;
  wo.split_bytes = opts_.split_bytes;
  wo.split_duration_ns = opts_.split_duration_ns;
  writer_ = std::make_unique<record::McapWriter>(path_, wo);  // throws when the file cannot be created
  waitset_ = std::make_unique<ReaderWaitSet>(p.handle());
  std::vector<const TopicInfo*> seen;
  for (const TopicInfo* t : opts_.topics) {
    if (std::find(seen.begin(), seen.end(), t) != seen.end()) continue;
    seen.push_back(t);
    auto r = std::make_unique<Recorded>();
    r->info = t;
    r->ros_name = p.ros_name(t->name);
    r->channel = writer_->add_channel(schema_for(std::string(t->ros_type)), r->ros_name, "cdr",
                                      {{"offered_qos_profiles", offered_qos_yaml(t->writer_qos())}});
    QosProfile q = t->reader_qos();
    if (opts_.keep_all) q.keep_all = true;
    r->sub = std::make_unique<Subscription>(p, t->name, t->descriptor, q);
    waitset_->attach(r->sub->reader(), r->ros_name);
    if (t->name == "/clock") clock_rec_ = r.get();
    rec_.push_back(std::move(r));
  }
  if (opts_.log_source_time && clock_rec_ == nullptr) {
    const TopicInfo* clock = find_topic("/clock");
    clock_sub_ = std::make_unique<Subscription>(p, clock->name, clock->descriptor, clock->reader_qos());
  }
}

DdsRecorder::~DdsRecorder() {
  try {
    stop();
  } catch (...) {  // a destructor must not throw; stop() reports errors to callers that call it
  }
}

void DdsRecorder::fail(const std::exception& e) {
  if (!error_.empty()) return;
  error_ = e.what();
  writer_closed_ = true;
  if (opts_.on_error) opts_.on_error(error_);
}

std::string DdsRecorder::error() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return error_;
}

void DdsRecorder::add_attachment(const std::string& name, const std::string& media_type, const std::string& data) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (writer_closed_) return;
  try {
    writer_->add_attachment(
        name, media_type, receipt_time_ns(), receipt_time_ns(),
        std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(data.data()), data.size()));
  } catch (const std::runtime_error& e) {
    fail(e);
  }
}

std::uint16_t DdsRecorder::schema_for(const std::string& ros_type) {
  auto s = schemas_.find(ros_type);
  if (s == schemas_.end())
    s = schemas_.emplace(ros_type, writer_->add_schema(ros_type, "ros2msg", msgs::ros2msg_definition(ros_type))).first;
  return s->second;
}

std::uint16_t DdsRecorder::add_cdr_channel(const std::string& topic, const std::string& ros_type,
                                           const std::map<std::string, std::string>& metadata) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (writer_closed_) return 0;  // its messages are then counted as lost
  try {
    return writer_->add_channel(schema_for(ros_type), topic, "cdr", metadata);
  } catch (const std::runtime_error& e) {
    fail(e);
    return 0;
  }
}

void DdsRecorder::write(std::uint16_t channel, std::uint32_t sequence, std::uint64_t log_time,
                        std::uint64_t publish_time, std::span<const std::uint8_t> data) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (!error_.empty()) {
    lost_.fetch_add(1);
    return;
  }
  if (writer_closed_) return;  // a late write after stop(): not part of the recording
  try {
    writer_->write(channel, sequence, log_time, publish_time, data);
  } catch (const std::runtime_error& e) {
    fail(e);
    lost_.fetch_add(1);
  }
}

void DdsRecorder::add_metadata(const std::string& name, const std::map<std::string, std::string>& values) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (writer_closed_) return;
  try {
    writer_->add_metadata(name, values);
  } catch (const std::runtime_error& e) {
    fail(e);
  }
}

bool DdsRecorder::done() const {
  return opts_.max_samples > 0 && total_.load() >= opts_.max_samples;
}

void DdsRecorder::note_clock(std::span<const std::uint8_t> cdr) {
  try {
    record::CdrReader in(cdr);
    const std::int64_t sec = in.i32();
    const std::int64_t nanosec = in.u32();
    if (sec >= 0 && nanosec < kNsPerSec) newest_clock_ = sec * kNsPerSec + nanosec;
  } catch (const std::exception&) {  // not a rosgraph_msgs/Clock we can read: keep the last one
  }
}

void DdsRecorder::take(Recorded& r) {
  const std::uint64_t total = total_.load();
  const std::size_t max = opts_.max_samples > 0 ? static_cast<std::size_t>(opts_.max_samples - total) : 256;
  if (max == 0) return;
  std::size_t written = 0;
  const bool is_clock = &r == clock_rec_;
  take_serialized(
      r.sub->reader(),
      [&](std::span<const std::uint8_t> bytes, const dds_sample_info_t& info) {
        if (is_clock) note_clock(bytes);
        if (!error_.empty()) {  // the file failed: drain the reader, count what is lost
          lost_.fetch_add(1);
          return;
        }
        const std::uint64_t now = receipt_time_ns();
        const std::uint64_t pub = source_time_or(info, now);
        std::uint64_t log = now;
        if (opts_.log_source_time) {
          log = sim_log_time(pub, newest_clock_, now);
          if (log != pub) at_clock_.fetch_add(1);
        }
        try {
          writer_->write(r.channel, r.sequence++, log, pub, bytes);
          ++written;
        } catch (const std::runtime_error& e) {
          fail(e);
          lost_.fetch_add(1);
        }
      },
      scratch_, max);
  r.count.fetch_add(written);
  total_.fetch_add(written);
}

void DdsRecorder::take_all() {
  std::lock_guard<std::mutex> lock(mutex_);
  // The clock first: a sample is logged against the newest /clock that reached the recorder
  // before it was taken.
  if (clock_sub_) {
    take_serialized(
        clock_sub_->reader(), [&](std::span<const std::uint8_t> bytes, const dds_sample_info_t&) { note_clock(bytes); },
        scratch_, 256);
  } else if (clock_rec_ != nullptr) {
    take(*clock_rec_);
  }
  for (auto& rp : rec_) {
    if (rp.get() == clock_rec_) continue;
    if (done()) break;
    take(*rp);
  }
}

void DdsRecorder::loop() {
  while (!stop_.load() && !done()) {
    if (waitset_->wait(100 * kNsPerMs)) take_all();
    cpu_ns_.store(thread_cpu_now());
  }
}

void DdsRecorder::start() {
  if (thread_.joinable() || closed_) return;
  stop_.store(false);
  thread_ = std::thread([this] { loop(); });
}

void DdsRecorder::stop() {
  if (closed_) return;
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  closed_ = true;
  // What the readers hold when stopped is still written (keep-all: every sample delivered).
  if (!done()) {
    std::size_t before = 0;
    do {
      before = static_cast<std::size_t>(total_.load());
      take_all();
    } while (total_.load() != before && !done());
  }
  std::lock_guard<std::mutex> lock(mutex_);
  if (!error_.empty()) return;  // the writer closed the file where it failed
  writer_closed_ = true;
  try {
    writer_->close();
  } catch (const std::runtime_error& e) {
    fail(e);
  }
}

std::vector<DdsRecorder::TopicCount> DdsRecorder::counts() const {
  std::vector<TopicCount> out;
  for (const auto& r : rec_) out.push_back({r->ros_name, std::string(r->info->ros_type), r->count.load()});
  return out;
}

std::uint64_t DdsRecorder::file_bytes() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return writer_->stats().file_bytes;
}

std::vector<std::filesystem::path> DdsRecorder::files() const {
  const std::lock_guard<std::mutex> lock(mutex_);
  return writer_ ? writer_->files() : std::vector<std::filesystem::path>{path_};
}

}  // namespace regolith::dds
