#pragma once
// McapWriter: writes an MCAP file (profile "ros2" by default) with chunked, optionally
// zstd-compressed messages, Message Index records after every chunk and, on close(), a summary
// (Schema, Channel, Statistics, Chunk / Attachment / Metadata Index records), Summary Offset
// records and the Footer. See record/README.md for the layout.
//
// Schema, Channel, Attachment and Metadata records go straight to the data section when added;
// messages are collected in the open chunk, which is written when it reaches
// McapWriterOptions::chunk_size bytes, on flush() and on close(). A crash therefore loses at most
// the open chunk: everything before it stays readable (McapReader reports the file truncated).
//
// Not thread-safe; write() allocates only while the chunk buffer and the per-channel index grow
// (the buffers are reused from chunk to chunk).
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

#include "regolith/record/mcap.hpp"

namespace regolith::record {

struct McapWriterOptions {
  std::string profile = "ros2";      ///< Header.profile
  std::string library = "regolith";  ///< Header.library (free-form writer name / version)
  Compression compression = Compression::kZstd;
  int zstd_level = 1;                   ///< 1 (fastest) .. 19; 1 keeps up with a rover's camera streams
  std::uint64_t chunk_size = 1U << 20;  ///< bytes of uncompressed records that close a chunk
  bool chunk_crc = true;                ///< Chunk.uncompressed_crc (0 = not computed)
  bool data_section_crc = true;         ///< DataEnd.data_section_crc
  bool summary_crc = true;              ///< Footer.summary_crc
  /// Split the recording into files: a new file starts before a message that would go into a
  /// file already holding split_bytes bytes, or whose log time is split_duration_ns or more after
  /// the file's first message (0 = never). Every file is a complete MCAP file with all schemas,
  /// channels (same ids), metadata and attachments: each opens on its own. Names: the given path,
  /// then <stem>_001<ext>, <stem>_002<ext>, ... (mcap_split_path).
  std::uint64_t split_bytes = 0;
  std::uint64_t split_duration_ns = 0;
  void validate() const;  ///< throws FieldError (McapWriterOptions.<field>)
};

/// The name of file `index` of a split recording: `path` itself for 0, else <stem>_NNN<ext>
/// beside it (drive.mcap -> drive_001.mcap).
std::filesystem::path mcap_split_path(const std::filesystem::path& path, std::size_t index);

/// The files of the recording that starts at `first`: `first`, then mcap_split_path(first, 1),
/// (first, 2), ... for as long as they exist (a recording that was not split: `first` alone).
/// Whether a sibling belongs to the same recording is the reader's to check (e.g. the HAL time
/// origin in its metadata).
std::vector<std::filesystem::path> mcap_split_files(const std::filesystem::path& first);

/// Totals so far over every file of the recording (a split recording's Statistics records hold
/// each file's own counts).
struct McapWriterStats {
  std::uint64_t messages = 0;
  std::uint64_t chunks = 0;         ///< chunks written (the open one not included)
  std::uint64_t message_bytes = 0;  ///< payload bytes passed to write()
  std::uint64_t file_bytes = 0;     ///< bytes written to the files
};

class McapWriter {
 public:
  /// Creates (truncates) `path` and writes the magic and the Header. Throws std::runtime_error
  /// naming the file when it cannot be created.
  explicit McapWriter(const std::filesystem::path& path, McapWriterOptions options = {});
  ~McapWriter();  ///< close(), errors swallowed: call close() to see them
  McapWriter(const McapWriter&) = delete;
  McapWriter& operator=(const McapWriter&) = delete;

  /// A schema (e.g. name "sensor_msgs/msg/JointState", encoding "ros2msg", data the .msg text).
  /// Returns its id (1, 2, ...).
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, std::span<const std::uint8_t> data);
  std::uint16_t add_schema(const std::string& name, const std::string& encoding, const std::string& data);

  /// A channel on `schema_id` (0 = no schema; otherwise an id from add_schema, else
  /// std::invalid_argument). Returns its id (1, 2, ...). With the "ros2" profile the metadata key
  /// `offered_qos_profiles` (the publisher's QoS policies as YAML, required by the profile) is
  /// added empty when the caller does not give it.
  std::uint16_t add_channel(std::uint16_t schema_id, const std::string& topic, const std::string& message_encoding,
                            const std::map<std::string, std::string>& metadata = {});

  /// One message on `channel_id` (an id from add_channel, else std::invalid_argument); times in ns.
  void write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns, std::uint64_t publish_time_ns,
             std::span<const std::uint8_t> data);

  /// A Metadata record (e.g. name "regolith_deployment", key/values) in the data section.
  void add_metadata(const std::string& name, const std::map<std::string, std::string>& values);

  /// An Attachment record (e.g. the deployment YAML, media type "application/yaml").
  void add_attachment(const std::string& name, const std::string& media_type, std::uint64_t log_time_ns,
                      std::uint64_t create_time_ns, std::span<const std::uint8_t> data);

  /// Writes the open chunk (if any) and flushes the C library buffer to the kernel.
  void flush();

  /// Writes the open chunk, DataEnd, the summary, the summary offsets, the Footer and the magic,
  /// and closes the file. Idempotent. Throws std::runtime_error naming the file on an I/O error.
  void close();

  bool is_open() const { return file_ != nullptr; }
  const McapWriterStats& stats() const { return stats_; }
  /// The file being written (the last one once closed).
  const std::filesystem::path& path() const { return path_; }
  /// Every file written so far, in order (one unless the options split the recording).
  const std::vector<std::filesystem::path>& files() const { return files_; }

 private:
  struct ChunkIndexEntry {
    ChunkInfo info;
    std::map<std::uint16_t, std::uint64_t> message_index_offsets;
    std::uint64_t message_index_length = 0;
  };
  struct AttachmentIndexEntry {
    AttachmentInfo info;
    std::uint64_t length = 0;
  };
  struct MetadataIndexEntry {
    std::uint64_t offset = 0, length = 0;
    std::string name;
  };

  // To the file; update_crc: add the bytes to the data-section CRC (false: the caller folds in a
  // CRC it already has).
  void write_out(const void* data, std::size_t size, bool update_crc = true);
  void write_record(const std::vector<std::uint8_t>& record);
  void write_chunk();
  void open_file();        // creates path_, writes the magic and the Header; resets the per-file state
  void finish_file();      // the open chunk, DataEnd, summary, offsets, Footer; closes the file
  void start_next_file();  // finish this file, open the next, repeat schemas/channels/metadata/attachments
  void write_metadata_record(const std::string& name, const std::map<std::string, std::string>& values);
  void write_attachment_record(const std::string& name, const std::string& media_type, std::uint64_t log_time_ns,
                               std::uint64_t create_time_ns, std::span<const std::uint8_t> data);
  void check_open(const char* what) const;
  [[noreturn]] void io_error(const char* what) const;

  std::filesystem::path base_path_, path_;
  std::vector<std::filesystem::path> files_;
  McapWriterOptions options_;
  std::FILE* file_ = nullptr;
  void* zstd_ctx_ = nullptr;    // ZSTD_CCtx*, reused for every chunk
  std::uint64_t offset_ = 0;    // bytes written
  std::uint32_t data_crc_ = 0;  // running CRC of every byte written before DataEnd
  bool in_data_section_ = true;

  std::vector<Schema> schemas_;
  std::vector<Channel> channels_;
  // repeated at the start of every file of a split recording
  struct KeptMetadata {
    std::string name;
    std::map<std::string, std::string> values;
  };
  struct KeptAttachment {
    std::string name, media_type;
    std::uint64_t log_time = 0, create_time = 0;
    std::vector<std::uint8_t> data;
  };
  std::vector<KeptMetadata> kept_metadata_;
  std::vector<KeptAttachment> kept_attachments_;
  // per file
  std::map<std::uint16_t, std::uint64_t> channel_counts_;
  std::uint64_t file_messages_ = 0;
  std::uint64_t message_start_ = 0, message_end_ = 0;
  std::uint64_t bytes_before_ = 0;  // bytes of the files already closed

  // open chunk
  std::vector<std::uint8_t> chunk_;                      // uncompressed records
  std::vector<std::uint8_t> compressed_;                 // reused zstd output buffer
  std::vector<std::uint8_t> scratch_;                    // reused record buffer
  std::vector<std::vector<std::uint64_t>> chunk_index_;  // per channel id: (log_time, offset) pairs
  std::vector<std::uint16_t> chunk_channels_;            // channels with messages in the open chunk
  std::uint64_t chunk_start_ = 0, chunk_end_ = 0;
  std::uint64_t chunk_messages_ = 0;

  std::vector<ChunkIndexEntry> chunk_indexes_;
  std::vector<AttachmentIndexEntry> attachment_indexes_;
  std::vector<MetadataIndexEntry> metadata_indexes_;
  McapWriterStats stats_;
};

}  // namespace regolith::record
