#include "regolith/record/cdr.hpp"

#include <stdexcept>

namespace regolith::record {

CdrWriter::CdrWriter(std::vector<std::uint8_t>& out) : out_(out) {
  out_.clear();
  const std::uint8_t encapsulation[4] = {0x00, 0x01, 0x00, 0x00};  // CDR_LE, no options
  raw(encapsulation, 4);
}

void CdrWriter::raw(const void* p, std::size_t n) {
  const auto* b = static_cast<const std::uint8_t*>(p);
  out_.insert(out_.end(), b, b + n);
}

void CdrWriter::aligned(const void* p, std::size_t n) {
  while ((out_.size() - 4) % n != 0) out_.push_back(0);
  raw(p, n);  // little-endian host (x86-64, arm64): the value's bytes are the wire bytes
}

void CdrWriter::string(std::string_view s) {
  u32(static_cast<std::uint32_t>(s.size() + 1));
  raw(s.data(), s.size());
  u8(0);
}

void CdrWriter::bytes(const void* data, std::size_t n) {
  u32(static_cast<std::uint32_t>(n));
  raw(data, n);
}

void CdrWriter::f64_sequence(std::span<const double> v) {
  u32(static_cast<std::uint32_t>(v.size()));
  for (double x : v) f64(x);
}

void CdrWriter::header(std::int64_t stamp_ns, std::string_view frame_id) {
  // builtin_interfaces/Time: int32 sec, uint32 nanosec (nanosec always in [0, 1e9)).
  std::int64_t sec = stamp_ns / 1000000000;
  std::int64_t nsec = stamp_ns % 1000000000;
  if (nsec < 0) {
    nsec += 1000000000;
    --sec;
  }
  i32(static_cast<std::int32_t>(sec));
  u32(static_cast<std::uint32_t>(nsec));
  string(frame_id);
}

CdrReader::CdrReader(std::span<const std::uint8_t> payload) : p_(payload) {
  if (p_.size() < 4) throw std::out_of_range("CDR: payload shorter than its 4-byte encapsulation header");
  if (p_[0] != 0x00 || p_[1] != 0x01)
    throw std::out_of_range("CDR: encapsulation " + std::to_string(p_[0]) + " " + std::to_string(p_[1]) +
                            " is not little-endian plain CDR (00 01)");
}

const std::uint8_t* CdrReader::need(std::size_t n, std::size_t align) {
  if (align > 1) pos_ += (align - (pos_ - 4) % align) % align;
  if (pos_ > p_.size() || p_.size() - pos_ < n)
    throw std::out_of_range("CDR: " + std::to_string(n) + " bytes needed at offset " + std::to_string(pos_) + " of a " +
                            std::to_string(p_.size()) + "-byte payload");
  const std::uint8_t* at = p_.data() + pos_;
  pos_ += n;
  return at;
}

std::uint8_t CdrReader::u8() {
  return *need(1, 1);
}

std::uint32_t CdrReader::u32() {
  std::uint32_t v;
  std::memcpy(&v, need(4, 4), 4);
  return v;
}

std::int32_t CdrReader::i32() {
  std::int32_t v;
  std::memcpy(&v, need(4, 4), 4);
  return v;
}

double CdrReader::f64() {
  double v;
  std::memcpy(&v, need(8, 8), 8);
  return v;
}

std::string CdrReader::string() {
  const std::uint32_t n = u32();
  if (n == 0) return {};
  const std::uint8_t* s = need(n, 1);
  return std::string(reinterpret_cast<const char*>(s), n - 1);
}

std::span<const std::uint8_t> CdrReader::bytes() {
  const std::uint32_t n = u32();
  return {need(n, 1), n};
}

std::vector<double> CdrReader::f64_sequence() {
  const std::uint32_t n = u32();
  if (n > (p_.size() - pos_) / 8 + 1)
    throw std::out_of_range("CDR: sequence of " + std::to_string(n) + " doubles in a " + std::to_string(p_.size()) +
                            "-byte payload");
  std::vector<double> v(n);
  for (auto& x : v) x = f64();
  return v;
}

std::int64_t CdrReader::header(std::string* frame_id) {
  const std::int64_t sec = i32();
  const std::int64_t nsec = u32();
  std::string f = string();
  if (frame_id != nullptr) *frame_id = std::move(f);
  return sec * 1000000000 + nsec;
}

}  // namespace regolith::record
