#pragma once
// MCAP container format constants and the record types shared by McapWriter and McapReader
// (https://mcap.dev/spec, major version 0). All integers are little-endian; times are uint64
// nanoseconds since an epoch the recorder chooses (regolith: the process clock, TimeNs).
#include <array>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace regolith::record {

/// 0x89 'M' 'C' 'A' 'P' '0' '\r' '\n': first and last 8 bytes of every MCAP file.
inline constexpr std::array<std::uint8_t, 8> kMcapMagic = {0x89, 'M', 'C', 'A', 'P', 0x30, '\r', '\n'};

/// Record opcodes (spec "Records").
enum class Opcode : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

/// Name of an opcode for messages ("Chunk", "opcode 0x42" for unknown / private ones).
std::string opcode_name(std::uint8_t op);

/// Chunk compression. MCAP names: "" and "zstd".
enum class Compression { kNone, kZstd };
const char* compression_name(Compression c);

struct Schema {
  std::uint16_t id = 0;  ///< never 0 in a file (0 = "no schema" in a Channel)
  std::string name;      ///< e.g. "sensor_msgs/msg/JointState"
  std::string encoding;  ///< e.g. "ros2msg"
  std::vector<std::uint8_t> data;
};

struct Channel {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;   ///< 0: no schema
  std::string topic;             ///< e.g. "/rover1/joint_states"
  std::string message_encoding;  ///< e.g. "cdr"
  std::map<std::string, std::string> metadata;
};

struct Metadata {
  std::string name;
  std::map<std::string, std::string> values;
};

/// An Attachment record without its data (McapReader::read_attachment gives the bytes).
struct AttachmentInfo {
  std::uint64_t offset = 0;                     ///< byte offset of the record in the file
  std::uint64_t log_time = 0, create_time = 0;  ///< ns
  std::string name, media_type;
  std::uint64_t data_size = 0;  ///< bytes
};

/// Location and contents of one Chunk record (from a Chunk Index, or found by scanning).
struct ChunkInfo {
  std::uint64_t offset = 0;  ///< byte offset of the Chunk record (its opcode) in the file
  std::uint64_t length = 0;  ///< bytes of the whole record, opcode and length included
  std::uint64_t message_start_time = 0, message_end_time = 0;  ///< ns; 0 when no messages
  std::string compression;                                     ///< "", "zstd", "lz4", ...
  std::uint64_t compressed_size = 0, uncompressed_size = 0;    ///< bytes of the records field
};

}  // namespace regolith::record
