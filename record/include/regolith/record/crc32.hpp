#pragma once
// CRC-32/ISO-HDLC (polynomial 0x04C11DB7 reflected, init and final xor 0xFFFFFFFF), the CRC of
// zlib's crc32() and of MCAP's chunk, data-section, summary and attachment checksums.
#include <cstddef>
#include <cstdint>

namespace regolith::record {

/// Running CRC: crc32_update(0, a) then crc32_update(that, b) == crc32 of a followed by b.
std::uint32_t crc32_update(std::uint32_t crc, const void* data, std::size_t size);

inline std::uint32_t crc32(const void* data, std::size_t size) {
  return crc32_update(0, data, size);
}

/// The CRC of A followed by B from crc(A), crc(B) and B's length, without reading the bytes again
/// (polynomial arithmetic: crc(A) * x^(8 len_b) mod P, xor crc(B)). The writer uses it to fold an
/// uncompressed chunk, whose CRC it has already computed, into the data-section CRC.
std::uint32_t crc32_combine(std::uint32_t crc_a, std::uint32_t crc_b, std::uint64_t len_b);

}  // namespace regolith::record
