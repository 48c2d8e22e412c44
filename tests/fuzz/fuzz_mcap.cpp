// libFuzzer target: the MCAP reader (regolith::record::McapReader) on any bytes: magic, Header,
// Footer and summary (fast path), the data-section scan, chunk decompression (zstd) and CRCs,
// every message, every attachment, and the `regolith log info` text. The only exception allowed
// out of the reader is regolith::InputError (not an MCAP file); damage must be reported, not crash.
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "regolith/core/error.hpp"
#include "regolith/record/info.hpp"
#include "regolith/record/mcap_reader.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace regolith::record;
  for (const bool use_summary : {true, false}) {
    McapReaderOptions o;
    o.use_summary = use_summary;
    o.max_record_bytes = 16U << 20;  // hostile sizes must be refused, not allocated
    try {
      McapReader r(std::vector<std::uint8_t>(data, data + size), "fuzz.mcap", o);
      std::uint64_t sum = 0;
      auto problems =
          r.for_each_message([&](const MessageView& m) { sum += m.log_time + m.data.size() + m.channel.topic.size(); });
      for (const auto& a : r.info().attachments) {
        try {
          sum += r.read_attachment(a).size();
        } catch (const regolith::InputError&) {
        }
      }
      sum += format_info(r.info()).size() + problems.size();
      (void)sum;
    } catch (const regolith::InputError&) {
    }
  }
  return 0;
}
