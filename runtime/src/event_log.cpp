#include "regolith/runtime/event_log.hpp"

#include <algorithm>
#include <cstring>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"

namespace regolith::runtime {
namespace {

const char* kind_name(HealthEntry::Kind k) {
  switch (k) {
    case HealthEntry::Kind::kComponent: return "component";
    case HealthEntry::Kind::kRateGroup: return "rate group";
    case HealthEntry::Kind::kCamera: return "camera";
    case HealthEntry::Kind::kEncoders: return "encoders";
    case HealthEntry::Kind::kImu: return "imu";
  }
  return "?";
}

int badness(Level l) {
  switch (l) {
    case Level::kOk: return 0;
    case Level::kWarn: return 1;
    case Level::kStale: return 2;
    case Level::kError: return 3;
  }
  return 0;
}

std::string name_of(const HealthEntry& e) {
  return std::string(e.name.data(), strnlen(e.name.data(), e.name.size()));
}

constexpr std::size_t kMsgCapacity = 255;
constexpr std::size_t kNameCapacity = 63;

}  // namespace

std::vector<Event> HealthEvents::update(const HealthSnapshot& s) {
  std::vector<Event> out;
  std::vector<Seen> now;
  now.reserve(s.count);
  for (std::uint32_t i = 0; i < s.count && i < s.entries.size(); ++i) {
    const HealthEntry& e = s.entries[i];
    const std::string who = std::string(kind_name(e.kind)) + " " + name_of(e);
    Seen cur{who, e.level, e.slips, e.errors, e.late_start_slips, e.stall_slips};
    const auto prev = std::find_if(seen_.begin(), seen_.end(), [&](const Seen& p) { return p.key == who; });
    const Level before = prev != seen_.end() ? prev->level : Level::kOk;
    const std::string why = e.message != nullptr ? e.message : "";
    if (first_ && e.level != Level::kError) {
      // Start-up: inputs not yet delivered are "stale" in the very first snapshot. Warnings wait
      // for the next snapshot (reported then if they persist); errors are reported at once.
      cur.level = Level::kOk;
    } else if (badness(e.level) > badness(before)) {
      out.push_back({e.level == Level::kError ? Event::Severity::kError : Event::Severity::kWarn, who + ": " + why});
    } else if (e.level == Level::kOk && before != Level::kOk) {
      out.push_back({Event::Severity::kInfo, who + ": recovered (" + why + ")"});
    }
    if (e.kind == HealthEntry::Kind::kRateGroup && prev != seen_.end() && e.slips > prev->slips) {
      const std::uint64_t late = e.late_start_slips - std::min(e.late_start_slips, prev->late_start_slips);
      const std::uint64_t stalled = e.stall_slips - std::min(e.stall_slips, prev->stall_slips);
      out.push_back(
          {Event::Severity::kWarn, who + ": " + std::to_string(e.slips - prev->slips) + " cycle slips (" +
                                       (late > 0 ? std::to_string(late) + " from a late start, " : std::string()) +
                                       (stalled > 0 ? std::to_string(stalled) + " from a stall, " : std::string()) +
                                       std::to_string(e.slips) + " in total)"});
    }
    now.push_back(std::move(cur));
  }
  seen_ = std::move(now);
  first_ = false;
  return out;
}

struct RosoutSink::Impl {
  std::shared_ptr<dds::Outbox<msgs::rcl_interfaces::Log>> out;
};

RosoutSink::RosoutSink(dds::Participant& participant, std::string node, std::function<TimeNs()> now, double per_second,
                       double burst)
    : impl_(std::make_unique<Impl>()),
      node_(std::move(node)),
      now_(std::move(now)),
      per_second_(per_second),
      burst_(burst),
      tokens_(burst),
      refill_(now_()) {
  using Log = msgs::rcl_interfaces::Log;
  impl_->out = participant.make_outbox<Log>("/rosout", dds::find_topic("/rosout")->writer_qos(),
                                            dds::OutboxOptions{dds::OutboxMode::kFifo, 32},
                                            [](Log& m) { dds::reserve(m, kMsgCapacity, kNameCapacity); });
}

RosoutSink::~RosoutSink() = default;

bool RosoutSink::publish(std::uint8_t level, std::string_view text, const spdlog::source_loc& where) {
  msgs::rcl_interfaces::Log* m = impl_->out->begin();
  if (m == nullptr) return false;
  dds::set_stamp(m->stamp, now_());
  m->level = level;
  dds::copy_string(m->name, kNameCapacity, node_);
  dds::copy_string(m->msg, kMsgCapacity, text);
  dds::copy_string(m->file, kNameCapacity, where.filename != nullptr ? where.filename : "");
  dds::copy_string(m->function, kNameCapacity, where.funcname != nullptr ? where.funcname : "");
  m->line = where.line > 0 ? static_cast<std::uint32_t>(where.line) : 0u;
  impl_->out->commit();
  ++published_;
  return true;
}

void RosoutSink::sink_it_(const spdlog::details::log_msg& msg) {
  std::uint8_t level = 20;
  switch (msg.level) {
    case spdlog::level::trace:
    case spdlog::level::debug: level = 10; break;
    case spdlog::level::info: level = 20; break;
    case spdlog::level::warn: level = 30; break;
    case spdlog::level::err: level = 40; break;
    case spdlog::level::critical: level = 50; break;
    default: return;
  }
  if (level < 20) return;
  const TimeNs t = now_();
  if (t > refill_) tokens_ = std::min(burst_, tokens_ + per_second_ * to_seconds(t - refill_));
  refill_ = std::max(refill_, t);
  if (suppressed_ > 0 && tokens_ >= 2.0) {
    const std::string note = std::to_string(suppressed_) + " log messages suppressed (more than " +
                             std::to_string(static_cast<int>(per_second_)) + " per second)";
    if (publish(30, note, {})) tokens_ -= 1.0, suppressed_ = 0;
  }
  if (tokens_ < 1.0) {
    ++suppressed_, ++suppressed_total_;
    return;
  }
  tokens_ -= 1.0;
  if (!publish(level, std::string_view(msg.payload.data(), msg.payload.size()), msg.source))
    ++suppressed_, ++suppressed_total_;
}

}  // namespace regolith::runtime
