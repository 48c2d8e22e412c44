#pragma once
// CAN frames, the table-driven wheel-angle decoder shared by every encoder backend (SocketCAN,
// candump replay, bench transducers), and the can-utils `candump -l` log-line parser.
#include <array>
#include <cstdint>
#include <mutex>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "regolith/core/params.hpp"
#include "regolith/core/time.hpp"

namespace regolith::hal {

struct CanFrame {
  std::uint32_t id = 0;   ///< 11-bit or 29-bit identifier (no flag bits)
  bool extended = false;  ///< 29-bit identifier
  bool remote = false;    ///< RTR frame
  bool error = false;     ///< error frame (SocketCAN CAN_ERR_FLAG)
  bool fd = false;        ///< CAN FD frame
  std::uint8_t len = 0;   ///< payload bytes (0..8, 0..64 for FD)
  std::array<std::uint8_t, 64> data{};
  TimeNs stamp = 0;  ///< receive time on the process clock
};

/// Where one value sits in a CAN payload and how it becomes a physical quantity.
struct CanSignal {
  std::string name;  ///< wheel (or transducer) name
  std::uint32_t id = 0;
  bool extended = false;
  int byte_offset = 0;      ///< first payload byte
  int length = 4;           ///< bytes, 1..8
  bool big_endian = false;  ///< false = little endian (Intel), true = big endian (Motorola)
  bool is_signed = true;
  double scale = 1.0;   ///< physical units per count (rad/count for encoders)
  double offset = 0.0;  ///< added after scaling
  bool wrap = true;     ///< the counter wraps at 2^(8*length): unwrap into a continuous value
};

/// Read one CanSignal from YAML (`id`, `extended`, `byte_offset`, `length`, `endian`,
/// `signed`, `scale`, `offset`, `wrap`), validated (offset + length must fit in 8 bytes, ...).
CanSignal can_signal_from_params(Params& p, const std::string& name);

/// Decodes configured signals from frames, unwrapping wrap-around counters per signal.
class CanDecoder {
 public:
  explicit CanDecoder(std::vector<CanSignal> signals);
  const std::vector<CanSignal>& signals() const { return signals_; }

  /// For each signal carried by `frame`, calls `sink(signal_index, value)`. Returns the number of
  /// values decoded; frames with unknown ids return 0; a known id with too short a payload counts
  /// as `short_frames()` and returns 0.
  template <class Sink>
  int decode(const CanFrame& frame, Sink&& sink) {
    int n = 0;
    for (std::size_t i = 0; i < signals_.size(); ++i) {
      double v = 0.0;
      const Status s = decode_one(i, frame, v);
      if (s == Status::kOk) {
        sink(i, v);
        ++n;
      }
    }
    return n;
  }
  /// Raw (unscaled, sign-extended) integer of signal `i` in `frame`; false if not carried.
  bool raw_value(std::size_t i, const CanFrame& frame, std::int64_t& raw) const;
  /// Ids the decoder listens to (for kernel receive filters).
  std::vector<std::pair<std::uint32_t, bool>> ids() const;
  std::uint64_t short_frames() const { return short_frames_; }
  void reset();

 private:
  enum class Status { kOk, kOtherId, kShort };
  Status decode_one(std::size_t i, const CanFrame& frame, double& value);

  std::vector<CanSignal> signals_;
  std::vector<std::int64_t> last_raw_;
  std::vector<std::int64_t> turns_;  // accumulated wrap-arounds, in counts
  std::vector<bool> seen_;
  std::uint64_t short_frames_ = 0;
};

/// The raw frames a backend received, kept for recorders: a ring of `capacity` frames made at
/// construction. The backend's receive thread appends (push: a copy under a short lock, no
/// allocation); a recorder's thread reads them by number (since). Frames are numbered from 0 in
/// the order they were pushed.
class CanFrameHistory {
 public:
  explicit CanFrameHistory(std::size_t capacity = 1024);
  void push(const CanFrame& frame);
  /// Frames numbered `cursor` on, at most out.size(); advances `cursor` past them. Frames already
  /// overwritten are skipped (cursor jumps to the oldest held) and added to `missed`.
  std::size_t since(std::uint64_t& cursor, std::span<CanFrame> out, std::uint64_t& missed) const;
  std::uint64_t pushed() const;

 private:
  mutable std::mutex mutex_;
  std::vector<CanFrame> ring_;
  std::uint64_t next_ = 0;  // number of the next frame pushed
};

/// One `candump -l` line for `frame` on `interface_name` at `unix_time_ns` (no newline): the
/// inverse of parse_candump_line ("(1700000000.123456) can0 0CF#1A2B3C4D", "123#R", "123##1AABB").
std::string format_candump_line(const CanFrame& frame, const std::string& interface_name, std::int64_t unix_time_ns);

/// Parse one `candump -l` line: "(1700000000.123456) can0 0CF#1A2B3C4D". Also accepts remote
/// frames ("123#R"), CAN FD ("123##1AABB"), and 8-digit (extended) ids. On failure returns false
/// and sets `error` to a description of what is wrong.
bool parse_candump_line(std::string_view line, CanFrame& frame, std::string& interface_name, double& unix_time_s,
                        std::string& error);

}  // namespace regolith::hal
