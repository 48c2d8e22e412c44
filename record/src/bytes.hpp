#pragma once
// Little-endian serialisation helpers shared by the MCAP writer and reader (private header).
#include <cstdint>
#include <cstring>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace regolith::record::detail {

inline void put_u8(std::vector<std::uint8_t>& b, std::uint8_t v) {
  b.push_back(v);
}
inline void put_u16(std::vector<std::uint8_t>& b, std::uint16_t v) {
  b.push_back(static_cast<std::uint8_t>(v));
  b.push_back(static_cast<std::uint8_t>(v >> 8));
}
inline void put_u32(std::vector<std::uint8_t>& b, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
inline void put_u64(std::vector<std::uint8_t>& b, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) b.push_back(static_cast<std::uint8_t>(v >> (8 * i)));
}
inline void put_bytes(std::vector<std::uint8_t>& b, const void* data, std::size_t n) {
  const auto* p = static_cast<const std::uint8_t*>(data);
  b.insert(b.end(), p, p + n);
}
inline void put_string(std::vector<std::uint8_t>& b, std::string_view s) {
  put_u32(b, static_cast<std::uint32_t>(s.size()));
  put_bytes(b, s.data(), s.size());
}
inline void put_string_map(std::vector<std::uint8_t>& b, const std::map<std::string, std::string>& m) {
  std::uint64_t n = 0;
  for (const auto& [k, v] : m) n += 8 + k.size() + v.size();
  put_u32(b, static_cast<std::uint32_t>(n));
  for (const auto& [k, v] : m) {
    put_string(b, k);
    put_string(b, v);
  }
}
/// Overwrites 8 bytes at `at` (a length reserved earlier).
inline void patch_u64(std::vector<std::uint8_t>& b, std::size_t at, std::uint64_t v) {
  for (int i = 0; i < 8; ++i) b[at + static_cast<std::size_t>(i)] = static_cast<std::uint8_t>(v >> (8 * i));
}
/// Starts a record: opcode + a length placeholder; returns the position of the length.
inline std::size_t begin_record(std::vector<std::uint8_t>& b, std::uint8_t op) {
  b.push_back(op);
  const std::size_t at = b.size();
  put_u64(b, 0);
  return at;
}
inline void end_record(std::vector<std::uint8_t>& b, std::size_t length_at) {
  patch_u64(b, length_at, b.size() - length_at - 8);
}

inline std::uint16_t get_u16(const std::uint8_t* p) {
  return static_cast<std::uint16_t>(p[0] | (p[1] << 8));
}
inline std::uint32_t get_u32(const std::uint8_t* p) {
  std::uint32_t v = 0;
  for (int i = 3; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}
inline std::uint64_t get_u64(const std::uint8_t* p) {
  std::uint64_t v = 0;
  for (int i = 7; i >= 0; --i) v = (v << 8) | p[i];
  return v;
}

}  // namespace regolith::record::detail
