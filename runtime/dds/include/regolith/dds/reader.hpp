#pragma once
// Readers: a type-erased Subscription (descriptor + waitset; used by `regolith
// echo`) and the typed Reader<Msg> on top of it. Not for real-time threads:
// take() hands out loaned samples.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include <dds/dds.h>

#include "regolith/dds/participant.hpp"
#include "regolith/dds/qos.hpp"
#include "regolith/dds/types.hpp"

namespace regolith::dds {

class Subscription {
 public:
  /// Reader on `topic` (relative or absolute ROS name) of type `desc`. The
  /// profile's deadline is ignored (readers never request one).
  Subscription(Participant& p, std::string_view topic, const dds_topic_descriptor_t* desc, const QosProfile& qos);
  ~Subscription();
  Subscription(const Subscription&) = delete;
  Subscription& operator=(const Subscription&) = delete;

  /// Blocks until data is available or `timeout_ns` passed (<= 0: return at
  /// once). True if data.
  bool wait(TimeNs timeout_ns);
  /// Takes up to `max` samples; calls f(const void* sample, const
  /// dds_sample_info_t&) for each valid one (samples are loans, valid during
  /// the call). Returns the number of valid samples.
  template <class F>
  std::size_t take(F&& f, std::size_t max = 64) {
    constexpr std::size_t kBatch = 16;
    std::size_t total = 0;
    while (total < max) {
      void* buf[kBatch] = {};
      dds_sample_info_t info[kBatch];
      const std::size_t want = (max - total) < kBatch ? (max - total) : kBatch;
      const dds_return_t n = dds_take(reader_, buf, info, want, static_cast<std::uint32_t>(want));
      if (n < 0) check(n, "dds_take on " + topic_);
      if (n <= 0) break;
      for (dds_return_t i = 0; i < n && total < max; ++i) {
        if (!info[i].valid_data) continue;
        f(static_cast<const void*>(buf[i]), info[i]);
        ++total;
      }
      dds_return_loan(reader_, buf, n);
      if (static_cast<std::size_t>(n) < want) break;
    }
    return total;
  }
  std::uint32_t matched_writers() const;
  const std::string& topic() const { return topic_; }
  dds_entity_t reader() const { return reader_; }

 private:
  Participant* participant_ = nullptr;
  std::string topic_;
  dds_entity_t reader_ = 0;
  dds_entity_t waitset_ = 0;
  dds_entity_t readcond_ = 0;
};

template <class Msg>
class Reader {
 public:
  Reader(Participant& p, std::string_view topic, const QosProfile& qos)
      : sub_(p, topic, MsgTraits<Msg>::descriptor(), qos) {}
  bool wait(TimeNs timeout_ns) { return sub_.wait(timeout_ns); }
  /// f(const Msg&, const dds_sample_info_t&) for each valid sample.
  template <class F>
  std::size_t take(F&& f, std::size_t max = 64) {
    return sub_.take([&](const void* s, const dds_sample_info_t& info) { f(*static_cast<const Msg*>(s), info); }, max);
  }
  std::uint32_t matched_writers() const { return sub_.matched_writers(); }
  Subscription& subscription() { return sub_; }

 private:
  Subscription sub_;
};

}  // namespace regolith::dds
