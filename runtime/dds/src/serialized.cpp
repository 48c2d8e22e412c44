#include "regolith/dds/serialized.hpp"

#include <dds/ddsi/ddsi_serdata.h>

#include "regolith/dds/outbox.hpp"  // check(), DdsError

namespace regolith::dds {

std::size_t take_serialized(dds_entity_t reader,
                            const std::function<void(std::span<const std::uint8_t>, const dds_sample_info_t&)>& f,
                            std::vector<std::uint8_t>& scratch, std::size_t max) {
  constexpr std::uint32_t kBatch = 16;
  std::size_t total = 0;
  while (total < max) {
    ddsi_serdata* buf[kBatch] = {};
    dds_sample_info_t info[kBatch];
    const auto want = static_cast<std::uint32_t>((max - total) < kBatch ? (max - total) : kBatch);
    const dds_return_t n = dds_takecdr(reader, buf, want, info, DDS_ANY_STATE);
    check(n, "dds_takecdr");
    if (n == 0) break;
    std::size_t i = 0;
    try {
      for (; i < static_cast<std::size_t>(n); ++i) {
        if (info[i].valid_data) {
          const std::uint32_t size = ddsi_serdata_size(buf[i]);
          scratch.resize(size);
          ddsi_serdata_to_ser(buf[i], 0, size, scratch.data());
          f(std::span<const std::uint8_t>(scratch.data(), size), info[i]);
          ++total;
        }
        ddsi_serdata_unref(buf[i]);
      }
    } catch (...) {
      for (++i; i < static_cast<std::size_t>(n); ++i) ddsi_serdata_unref(buf[i]);
      throw;
    }
    if (static_cast<std::uint32_t>(n) < want) break;
  }
  return total;
}

ReaderWaitSet::ReaderWaitSet(dds_entity_t participant) {
  waitset_ = check(dds_create_waitset(participant), "dds_create_waitset");
}

ReaderWaitSet::~ReaderWaitSet() {
  for (const dds_entity_t c : conditions_) (void)dds_delete(c);
  if (waitset_ > 0) (void)dds_delete(waitset_);
}

void ReaderWaitSet::attach(dds_entity_t reader, const std::string& what) {
  const dds_entity_t c = check(dds_create_readcondition(reader, DDS_ANY_STATE), "dds_create_readcondition for " + what);
  conditions_.push_back(c);
  check(dds_waitset_attach(waitset_, c, static_cast<dds_attach_t>(conditions_.size())),
        "dds_waitset_attach for " + what);
}

bool ReaderWaitSet::wait(TimeNs timeout_ns) {
  const dds_return_t rc = dds_waitset_wait(waitset_, nullptr, 0, timeout_ns > 0 ? timeout_ns : 0);
  check(rc, "dds_waitset_wait");
  return rc > 0;
}

}  // namespace regolith::dds
