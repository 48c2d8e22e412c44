#pragma once
// Samples as serialized CDR bytes (for recorders: `regolith record` writes them to MCAP unchanged)
// and one waitset over several readers. Not for real-time threads.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <string>
#include <vector>

#include <dds/dds.h>

#include "regolith/core/time.hpp"

namespace regolith::dds {

/// Takes up to `max` samples from `reader` as serialized data (dds_takecdr) and calls
/// f(bytes, info) for each one with valid data. `bytes` is the sample as on the wire, starting
/// with the 4-byte CDR encapsulation header (e.g. 00 01 00 00 = plain CDR, little endian), and
/// lives in `scratch` until the next sample. Returns the number of valid samples. Throws DdsError.
std::size_t take_serialized(
    dds_entity_t reader,
    const std::function<void(std::span<const std::uint8_t> bytes, const dds_sample_info_t& info)>& f,
    std::vector<std::uint8_t>& scratch, std::size_t max = 64);

/// Now on the wall clock, ns since 1970: the receipt time MCAP log times and Foxglove message
/// times are given in.
inline std::uint64_t receipt_time_ns() {
  return static_cast<std::uint64_t>(realtime_now());
}

/// The sample's DDS source timestamp (the writer's clock: wall time, or the simulated ROS time of
/// a run under --sim-time, see Participant::set_source_clock), or `receipt_ns` if the writer set
/// none.
inline std::uint64_t source_time_or(const dds_sample_info_t& info, std::uint64_t receipt_ns) {
  return info.source_timestamp > 0 ? static_cast<std::uint64_t>(info.source_timestamp) : receipt_ns;
}

/// A waitset woken when any attached reader has data.
class ReaderWaitSet {
 public:
  explicit ReaderWaitSet(dds_entity_t participant);
  ~ReaderWaitSet();
  ReaderWaitSet(const ReaderWaitSet&) = delete;
  ReaderWaitSet& operator=(const ReaderWaitSet&) = delete;
  /// Wakes the waitset whenever `reader` holds a sample (any state).
  void attach(dds_entity_t reader, const std::string& what);
  /// Blocks until data or `timeout_ns` (<= 0: return at once). True if data.
  bool wait(TimeNs timeout_ns);

 private:
  dds_entity_t waitset_ = 0;
  std::vector<dds_entity_t> conditions_;
};

}  // namespace regolith::dds
