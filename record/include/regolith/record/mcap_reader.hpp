#pragma once
// McapReader: reads MCAP files written by McapWriter or by any other conforming writer.
//
// Opening validates the magic and the Header, then takes the fast path when the file ends with a
// Footer whose summary holds a Statistics record (schemas, channels, counts, time range and chunk
// list come from the summary, nothing else is read); otherwise - a file cut off mid-write, no
// summary, a summary CRC mismatch - it scans the data section record by record, decompressing
// every chunk and checking the CRCs.
//
// Damage never throws past the constructor: a file cut off mid-write is readable up to its last
// complete record (info().truncated, info().readable_end); a chunk whose CRC does not match or that
// cannot be decompressed is skipped and reported in info().problems with its byte offset. Only a
// file that is not MCAP at all (cannot be opened, wrong magic, no Header) throws regolith::InputError
// "FILE: byte N: ...".
#include <cstdint>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "regolith/record/mcap.hpp"

namespace regolith::record {

namespace detail {
class ByteSource;  // a file (pread) or bytes in memory
}

/// Damage found while reading: where (byte offset of the record in the file) and what.
struct ReadProblem {
  std::uint64_t offset = 0;
  std::string what;
};

struct McapFileInfo {
  std::string name;             ///< the path (or the name given with the bytes)
  std::uint64_t file_size = 0;  ///< bytes
  std::string profile, library;
  std::map<std::uint16_t, Schema> schemas;
  std::map<std::uint16_t, Channel> channels;
  std::map<std::uint16_t, std::uint64_t> message_counts;  ///< per channel id (readable messages)
  std::uint64_t message_count = 0;
  std::uint64_t message_start_time = 0, message_end_time = 0;  ///< ns log time; 0 without messages
  std::vector<ChunkInfo> chunks;                               ///< readable chunks, in file order
  std::vector<AttachmentInfo> attachments;
  std::vector<Metadata> metadata;
  bool from_summary = false;          ///< true: the fast path (summary); false: the data section was scanned
  bool truncated = false;             ///< the file ends before its Footer (cut off mid-write)
  std::uint64_t readable_end = 0;     ///< truncated: offset of the first incomplete record (bytes before it are read)
  std::vector<ReadProblem> problems;  ///< damaged records (CRC mismatches, undecodable chunks, summary errors)
};

struct McapReaderOptions {
  bool verify_crcs = true;                      ///< chunk, attachment, summary and data-section CRCs (those not 0)
  bool use_summary = true;                      ///< false: always scan the data section (checks every chunk's CRC)
  std::uint64_t max_record_bytes = 1ULL << 30;  ///< records / uncompressed chunks above this are refused
};

/// One message; `data` points into the reader's chunk buffer, valid during the callback only.
struct MessageView {
  const Channel& channel;
  std::uint32_t sequence;
  std::uint64_t log_time;      ///< ns
  std::uint64_t publish_time;  ///< ns
  std::span<const std::uint8_t> data;
};

class McapReader {
 public:
  /// Opens and indexes `path`. Throws regolith::InputError naming the file and byte offset when it
  /// cannot be opened or is not an MCAP file (wrong magic, no Header).
  explicit McapReader(const std::filesystem::path& path, McapReaderOptions options = {});
  /// The same on bytes in memory (fuzzing, tests); `name` is used in messages.
  McapReader(std::vector<std::uint8_t> bytes, std::string name, McapReaderOptions options = {});
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const McapFileInfo& info() const { return info_; }

  /// Calls `fn` for every readable message: chunk by chunk in file order, each chunk's messages in
  /// log-time order (messages outside chunks in file order). Returns the damage met on the way
  /// (chunks skipped, with offsets); exceptions thrown by `fn` propagate.
  [[nodiscard]] std::vector<ReadProblem> for_each_message(const std::function<void(const MessageView&)>& fn);
  /// Called from for_each_message's `fn`: no message after this one is read (a reader that found
  /// what it looked for leaves the remaining chunks undecompressed).
  void stop() { stop_ = true; }

  /// The data of an attachment from info().attachments. Throws InputError (file, offset) if unreadable.
  std::vector<std::uint8_t> read_attachment(const AttachmentInfo& a);

  /// "FILE: byte N: what", the form of every error message of the reader.
  std::string describe(const ReadProblem& p) const;

 private:
  using Emit = std::function<void(const MessageView&)>;
  void open();
  bool read_summary();
  /// The Metadata records a summary's Metadata Index points at (offset, length) into `s`;
  /// a bad one becomes a problem of `s`.
  void read_metadata(const std::vector<std::pair<std::uint64_t, std::uint64_t>>& metadata_at, McapFileInfo& s);
  /// The slow path: every record of the data section from the first after the Header, counted
  /// into `info` (emit == nullptr) or each message passed to `*emit`.
  void scan(McapFileInfo& info, const Emit* emit, std::vector<ReadProblem>& problems);
  /// The record at `pos` of the data section: its 9-byte prefix (opcode, length) into `prefix` and
  /// its content into `content`. False where the scan stops: the file ends or is cut off there
  /// (`info.truncated`), or the record cannot be read (a problem says why); `info.readable_end`
  /// is then `pos`.
  bool read_data_record(std::uint64_t pos, McapFileInfo& info, std::uint8_t* prefix, std::vector<std::uint8_t>& content,
                        std::vector<ReadProblem>& problems);
  /// One record of the data section (not DataEnd) into `info`, or its messages to `*emit`; a
  /// malformed record is a problem and the scan goes on.
  void scan_record(std::uint64_t pos, std::uint8_t op, const std::vector<std::uint8_t>& content, McapFileInfo& info,
                   const Emit* emit, std::vector<ReadProblem>& problems);
  bool process_chunk(std::uint64_t offset, const std::vector<std::uint8_t>& content, McapFileInfo& info,
                     const Emit* emit, bool count, std::vector<ReadProblem>& problems);
  [[noreturn]] void fail(std::uint64_t offset, const std::string& what) const;

  std::unique_ptr<detail::ByteSource> source_;
  McapReaderOptions options_;
  McapFileInfo info_;
  std::uint64_t data_start_ = 0;            // first record after the Header
  std::vector<std::uint8_t> chunk_buffer_;  // reused decompression buffer
  bool stop_ = false;                       // stop() was called during for_each_message
};

/// A HAL recording's identity and time frame, from a file's `regolith_hal` and `regolith_hal_end`
/// metadata (hal_recorder.hpp). The one reader of those records.
struct HalRecordingInfo {
  bool found = false;              ///< the file has `regolith_hal` metadata (a HAL recording)
  std::int64_t origin_ns = -1;     ///< process clock at the recording's start
  std::int64_t end_ns = -1;        ///< ... at its end (-1: not in this file: a cut-off or not-last split file)
  std::int64_t ros_offset_ns = 0;  ///< ROS time = process clock + this (simulated time: 0 but for a recorded replay)
  bool simulated = false;
  std::string recording_id;  ///< empty in files written before it existed
};
/// Throws InputError naming `file`, the record and the key when a number does not parse.
HalRecordingInfo hal_recording_info(const McapFileInfo& info, const std::string& file);

/// The files of the recording that starts at `first` (mcap_split_files), keeping only the
/// siblings that carry the same `regolith_hal` time origin and recording id as `first` (the same
/// recording; files without HAL metadata match each other): a stray `<stem>_001.mcap` from another run is left out.
/// Each file is opened to read its metadata (InputError naming a file that is not MCAP).
std::vector<std::filesystem::path> mcap_recording_files(const std::filesystem::path& first);

}  // namespace regolith::record
