#include "regolith/hal/can.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace regolith::hal {

CanSignal can_signal_from_params(Params& p, const std::string& name) {
  CanSignal s;
  s.name = name;
  s.extended = p.get<bool>("extended", false, {.doc = "29-bit identifier"});
  const auto id = p.require<std::int64_t>(
      "id", {.min = 0, .max = s.extended ? 0x1FFFFFFF : 0x7FF, .doc = "CAN identifier (decimal or 0x hex)"});
  s.id = static_cast<std::uint32_t>(id);
  s.byte_offset = p.get<int>("byte_offset", 0, {.unit = "byte", .min = 0, .max = 63, .doc = "first payload byte"});
  s.length = p.get<int>("length", 4, {.unit = "byte", .min = 1, .max = 8, .doc = "value width"});
  if (s.byte_offset + s.length > 64) p.fail("length", "byte_offset + length exceeds a CAN FD payload (64)");
  const std::string endian =
      p.get<std::string>("endian", "little", {.choices = {"little", "big"}, .doc = "byte order"});
  s.big_endian = endian == "big";
  s.is_signed = p.get<bool>("signed", true, {.doc = "two's complement value"});
  s.scale = p.get<double>("scale", 1.0, {.unit = "unit/count", .doc = "physical units (rad for encoders) per count"});
  if (s.scale == 0.0 || !std::isfinite(s.scale)) p.fail("scale", "must be finite and non-zero");
  s.offset = p.get<double>("offset", 0.0, {.doc = "added after scaling (rad for encoders)"});
  s.wrap = p.get<bool>("wrap", true, {.doc = "counter wraps at 2^(8*length): unwrap it"});
  return s;
}

CanDecoder::CanDecoder(std::vector<CanSignal> signals)
    : signals_(std::move(signals)),
      last_raw_(signals_.size(), 0),
      turns_(signals_.size(), 0),
      seen_(signals_.size(), false) {}

void CanDecoder::reset() {
  std::fill(last_raw_.begin(), last_raw_.end(), 0);
  std::fill(turns_.begin(), turns_.end(), 0);
  std::fill(seen_.begin(), seen_.end(), false);
}

std::vector<std::pair<std::uint32_t, bool>> CanDecoder::ids() const {
  std::vector<std::pair<std::uint32_t, bool>> out;
  for (const auto& s : signals_) {
    const std::pair<std::uint32_t, bool> k{s.id, s.extended};
    if (std::find(out.begin(), out.end(), k) == out.end()) out.push_back(k);
  }
  return out;
}

bool CanDecoder::raw_value(std::size_t i, const CanFrame& f, std::int64_t& raw) const {
  const CanSignal& s = signals_[i];
  if (f.error || f.remote || f.id != s.id || f.extended != s.extended) return false;
  if (s.byte_offset + s.length > f.len) return false;
  std::uint64_t u = 0;
  for (int b = 0; b < s.length; ++b) {
    const int idx = s.big_endian ? s.byte_offset + b : s.byte_offset + s.length - 1 - b;
    u = (u << 8) | f.data[static_cast<std::size_t>(idx)];
  }
  const int bits = 8 * s.length;
  if (s.is_signed && bits < 64 && (u >> (bits - 1)) & 1U) {
    u |= ~((std::uint64_t{1} << bits) - 1);  // sign-extend
  }
  raw = static_cast<std::int64_t>(u);
  return true;
}

CanDecoder::Status CanDecoder::decode_one(std::size_t i, const CanFrame& f, double& value) {
  const CanSignal& s = signals_[i];
  if (f.error || f.remote || f.id != s.id || f.extended != s.extended) return Status::kOtherId;
  std::int64_t raw = 0;
  if (!raw_value(i, f, raw)) {
    ++short_frames_;
    return Status::kShort;
  }
  std::int64_t unwrapped = raw;
  if (s.wrap && s.length < 8) {
    const std::int64_t span = std::int64_t{1} << (8 * s.length);
    if (seen_[i]) {
      std::int64_t d = raw - last_raw_[i];
      if (d > span / 2) turns_[i] -= span;
      if (d < -span / 2) turns_[i] += span;
    }
    unwrapped = raw + turns_[i];
  }
  last_raw_[i] = raw;
  seen_[i] = true;
  value = static_cast<double>(unwrapped) * s.scale + s.offset;
  return Status::kOk;
}

namespace {

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

}  // namespace

bool parse_candump_line(std::string_view line, CanFrame& frame, std::string& iface, double& unix_time_s,
                        std::string& error) {
  frame = CanFrame{};
  while (!line.empty() && (line.back() == '\n' || line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
  if (line.empty() || line.front() != '(') {
    error = "expected '(seconds.micros)' at the start of the line";
    return false;
  }
  const auto close = line.find(')');
  if (close == std::string_view::npos) {
    error = "missing ')' after the timestamp";
    return false;
  }
  const std::string ts(line.substr(1, close - 1));
  char* end = nullptr;
  unix_time_s = std::strtod(ts.c_str(), &end);
  if (ts.empty() || end != ts.c_str() + ts.size() || ts.find('.') == std::string::npos) {
    error = "bad timestamp '" + ts + "'";
    return false;
  }
  std::string_view rest = line.substr(close + 1);
  if (rest.empty() || rest.front() != ' ') {
    error = "expected a space after the timestamp";
    return false;
  }
  rest.remove_prefix(1);
  const auto sp = rest.find(' ');
  if (sp == std::string_view::npos || sp == 0) {
    error = "expected '<interface> <id>#<data>' after the timestamp";
    return false;
  }
  iface = std::string(rest.substr(0, sp));
  std::string_view body = rest.substr(sp + 1);
  const auto hash = body.find('#');
  if (hash == std::string_view::npos) {
    error = "missing '#' between identifier and data";
    return false;
  }
  const std::string_view id_text = body.substr(0, hash);
  if (id_text.size() != 3 && id_text.size() != 8) {
    error = "identifier '" + std::string(id_text) + "' must have 3 (standard) or 8 (extended) hex digits";
    return false;
  }
  std::uint32_t id = 0;
  for (char c : id_text) {
    const int d = hex_digit(c);
    if (d < 0) {
      error = "identifier '" + std::string(id_text) + "' is not hexadecimal";
      return false;
    }
    id = (id << 4) | static_cast<std::uint32_t>(d);
  }
  frame.extended = id_text.size() == 8;
  if (frame.extended && (id & 0x20000000U)) {
    frame.error = true;  // candump logs error frames with the CAN_ERR_FLAG bit set
    id &= 0x1FFFFFFFU;
  }
  if (!frame.extended && id > 0x7FF) {
    error = "standard identifier exceeds 0x7FF";
    return false;
  }
  frame.id = id;
  std::string_view data = body.substr(hash + 1);
  std::size_t max_len = 8;
  if (!data.empty() && data.front() == '#') {  // CAN FD: "##<flags><data>"
    frame.fd = true;
    max_len = 64;
    data.remove_prefix(1);
    if (data.empty() || hex_digit(data.front()) < 0) {
      error = "CAN FD frame needs a flags nibble after '##'";
      return false;
    }
    data.remove_prefix(1);
  } else if (!data.empty() && (data.front() == 'R' || data.front() == 'r')) {
    frame.remote = true;
    return true;
  }
  if (data.size() % 2 != 0) {
    error = "data '" + std::string(data) + "' has an odd number of hex digits";
    return false;
  }
  if (data.size() / 2 > max_len) {
    error = "data has " + std::to_string(data.size() / 2) + " bytes (max " + std::to_string(max_len) + ")";
    return false;
  }
  for (std::size_t i = 0; i < data.size(); i += 2) {
    const int hi = hex_digit(data[i]);
    const int lo = hex_digit(data[i + 1]);
    if (hi < 0 || lo < 0) {
      error = "data '" + std::string(data) + "' is not hexadecimal";
      return false;
    }
    frame.data[i / 2] = static_cast<std::uint8_t>(hi * 16 + lo);
  }
  frame.len = static_cast<std::uint8_t>(data.size() / 2);
  return true;
}

}  // namespace regolith::hal

namespace regolith::hal {

CanFrameHistory::CanFrameHistory(std::size_t capacity) : ring_(std::max<std::size_t>(capacity, 1)) {}

void CanFrameHistory::push(const CanFrame& frame) {
  std::lock_guard<std::mutex> lock(mutex_);
  ring_[next_ % ring_.size()] = frame;
  ++next_;
}

std::size_t CanFrameHistory::since(std::uint64_t& cursor, std::span<CanFrame> out, std::uint64_t& missed) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const std::uint64_t oldest = next_ > ring_.size() ? next_ - ring_.size() : 0;
  if (cursor < oldest) {
    missed += oldest - cursor;
    cursor = oldest;
  }
  std::size_t n = 0;
  for (; cursor < next_ && n < out.size(); ++cursor, ++n) out[n] = ring_[cursor % ring_.size()];
  return n;
}

std::uint64_t CanFrameHistory::pushed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return next_;
}

std::string format_candump_line(const CanFrame& f, const std::string& interface_name, std::int64_t unix_time_ns) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  const std::int64_t us = unix_time_ns >= 0 ? unix_time_ns / 1000 : -((-unix_time_ns + 999) / 1000);
  const std::int64_t sec = us >= 0 ? us / 1000000 : (us - 999999) / 1000000;
  char head[48];
  std::snprintf(head, sizeof head, "(%lld.%06lld) ", static_cast<long long>(sec),
                static_cast<long long>(us - sec * 1000000));
  std::string line = head;
  line += interface_name;
  line += ' ';
  char id[12];
  if (f.error) {
    std::snprintf(id, sizeof id, "%08X", static_cast<unsigned>((f.id & 0x1FFFFFFFU) | 0x20000000U));
  } else if (f.extended) {
    std::snprintf(id, sizeof id, "%08X", static_cast<unsigned>(f.id & 0x1FFFFFFFU));
  } else {
    std::snprintf(id, sizeof id, "%03X", static_cast<unsigned>(f.id & 0x7FFU));
  }
  line += id;
  line += '#';
  if (f.remote && !f.fd) {
    line += 'R';
    return line;
  }
  if (f.fd) line += "#0";  // flags nibble: not kept by CanFrame
  const std::size_t len = std::min<std::size_t>(f.len, f.fd ? 64 : 8);
  for (std::size_t i = 0; i < len; ++i) {
    line += kHex[f.data[i] >> 4];
    line += kHex[f.data[i] & 0xF];
  }
  return line;
}

}  // namespace regolith::hal
