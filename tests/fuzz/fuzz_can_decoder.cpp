// libFuzzer target: raw CAN frames (id, flags, length, payload from the input bytes) through the
// table-driven decoder with little / big endian, signed / unsigned, wrapping and 1..8 byte
// signals; the length byte may claim more than the payload holds.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstring>

#include "regolith/hal/can.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static regolith::hal::CanDecoder decoder({{"a", 0x100, false, 0, 1, false, true, 1.0, 0.0, true},
                                            {"b", 0x100, false, 1, 2, true, true, 0.01, 0.0, true},
                                            {"c", 0x100, false, 3, 4, false, false, 1e-3, 2.0, true},
                                            {"d", 0x100, false, 0, 8, true, true, 1e-9, 0.0, false},
                                            {"e", 0x1ABCDEF, true, 5, 3, false, true, 1.0, 0.0, true}});
  std::size_t at = 0;
  while (at + 6 <= size) {
    regolith::hal::CanFrame f;
    std::uint32_t id = 0;
    std::memcpy(&id, data + at, 4);
    const std::uint8_t flags = data[at + 4];
    f.extended = (flags & 1) != 0;
    f.remote = (flags & 2) != 0;
    f.error = (flags & 4) != 0;
    f.fd = (flags & 8) != 0;
    f.id = (flags & 16) ? (f.extended ? 0x1ABCDEF : 0x100) : id & 0x1FFFFFFF;
    f.len = data[at + 5];  // may exceed what follows: the decoder must not trust it
    at += 6;
    const std::size_t n = std::min<std::size_t>({f.len, size - at, f.data.size()});
    std::memcpy(f.data.data(), data + at, n);
    at += n;
    double sum = 0.0;
    decoder.decode(f, [&](std::size_t, double v) { sum += v; });
    std::int64_t raw = 0;
    for (std::size_t i = 0; i < decoder.signals().size(); ++i) decoder.raw_value(i, f, raw);
    (void)sum;
  }
  return 0;
}
