// McapWriter: see mcap_writer.hpp; record layouts from the MCAP specification (mcap.dev/spec).
#include "regolith/record/mcap_writer.hpp"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <stdexcept>

#include <zstd.h>

#include "bytes.hpp"
#include "regolith/core/error.hpp"
#include "regolith/record/crc32.hpp"

namespace regolith::record {

using namespace detail;

std::string opcode_name(std::uint8_t op) {
  switch (static_cast<Opcode>(op)) {
    case Opcode::kHeader: return "Header";
    case Opcode::kFooter: return "Footer";
    case Opcode::kSchema: return "Schema";
    case Opcode::kChannel: return "Channel";
    case Opcode::kMessage: return "Message";
    case Opcode::kChunk: return "Chunk";
    case Opcode::kMessageIndex: return "MessageIndex";
    case Opcode::kChunkIndex: return "ChunkIndex";
    case Opcode::kAttachment: return "Attachment";
    case Opcode::kAttachmentIndex: return "AttachmentIndex";
    case Opcode::kStatistics: return "Statistics";
    case Opcode::kMetadata: return "Metadata";
    case Opcode::kMetadataIndex: return "MetadataIndex";
    case Opcode::kSummaryOffset: return "SummaryOffset";
    case Opcode::kDataEnd: return "DataEnd";
  }
  static const char* hex = "0123456789abcdef";
  return std::string("opcode 0x") + hex[op >> 4] + hex[op & 0xF];
}

const char* compression_name(Compression c) {
  return c == Compression::kZstd ? "zstd" : "";
}

namespace {

void append_schema(std::vector<std::uint8_t>& b, const Schema& sc) {
  const std::size_t at = begin_record(b, static_cast<std::uint8_t>(Opcode::kSchema));
  put_u16(b, sc.id);
  put_string(b, sc.name);
  put_string(b, sc.encoding);
  put_u32(b, static_cast<std::uint32_t>(sc.data.size()));
  put_bytes(b, sc.data.data(), sc.data.size());
  end_record(b, at);
}

void append_channel(std::vector<std::uint8_t>& b, const Channel& c) {
  const std::size_t at = begin_record(b, static_cast<std::uint8_t>(Opcode::kChannel));
  put_u16(b, c.id);
  put_u16(b, c.schema_id);
  put_string(b, c.topic);
  put_string(b, c.message_encoding);
  put_string_map(b, c.metadata);
  end_record(b, at);
}

}  // namespace

void McapWriterOptions::validate() const {
  if (zstd_level < 1 || zstd_level > ZSTD_maxCLevel())
    throw FieldError(
        "McapWriterOptions", "zstd_level",
        "must be in [1, " + std::to_string(ZSTD_maxCLevel()) + "] (got " + std::to_string(zstd_level) + ")");
  if (chunk_size < 1) throw FieldError("McapWriterOptions", "chunk_size", "must be >= 1 byte");
  if (split_bytes > 0 && split_bytes < 4096)
    throw FieldError("McapWriterOptions", "split_bytes",
                     "must be 0 (never) or >= 4096 bytes (got " + std::to_string(split_bytes) + ")");
}

std::filesystem::path mcap_split_path(const std::filesystem::path& path, std::size_t index) {
  if (index == 0) return path;
  char n[24];
  std::snprintf(n, sizeof n, "_%03zu", index);
  return path.parent_path() / (path.stem().string() + n + path.extension().string());
}

std::vector<std::filesystem::path> mcap_split_files(const std::filesystem::path& first) {
  std::vector<std::filesystem::path> files{first};
  std::error_code ec;
  for (std::size_t k = 1; std::filesystem::is_regular_file(mcap_split_path(first, k), ec); ++k)
    files.push_back(mcap_split_path(first, k));
  return files;
}

McapWriter::McapWriter(const std::filesystem::path& path, McapWriterOptions options)
    : base_path_(path), path_(path), options_(std::move(options)) {
  options_.validate();
  if (options_.compression == Compression::kZstd) {
    zstd_ctx_ = ZSTD_createCCtx();
    if (zstd_ctx_ == nullptr) throw std::runtime_error("cannot create a zstd context for " + path_.string());
  }
  chunk_.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(options_.chunk_size + (1U << 16), 64U << 20)));
  try {
    open_file();
  } catch (...) {
    ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_ctx_));
    zstd_ctx_ = nullptr;
    throw;
  }
}

void McapWriter::open_file() {
  file_ = std::fopen(path_.c_str(), "wb");
  if (file_ == nullptr) throw std::runtime_error("cannot create " + path_.string() + ": " + std::strerror(errno));
  std::setvbuf(file_, nullptr, _IOFBF, 1U << 16);
  files_.push_back(path_);
  offset_ = 0;
  data_crc_ = 0;
  in_data_section_ = true;
  channel_counts_.clear();
  file_messages_ = 0;
  message_start_ = message_end_ = 0;
  chunk_indexes_.clear();
  attachment_indexes_.clear();
  metadata_indexes_.clear();
  write_out(kMcapMagic.data(), kMcapMagic.size());
  scratch_.clear();
  const std::size_t at = begin_record(scratch_, static_cast<std::uint8_t>(Opcode::kHeader));
  put_string(scratch_, options_.profile);
  put_string(scratch_, options_.library);
  end_record(scratch_, at);
  write_record(scratch_);
}

void McapWriter::start_next_file() {
  finish_file();
  path_ = mcap_split_path(base_path_, files_.size());
  open_file();
  // The same schemas and channels under the same ids, the metadata and the attachments: every
  // file of the recording opens on its own.
  for (const Schema& sc : schemas_) {
    scratch_.clear();
    append_schema(scratch_, sc);
    write_record(scratch_);
  }
  for (const Channel& c : channels_) {
    scratch_.clear();
    append_channel(scratch_, c);
    write_record(scratch_);
  }
  for (const KeptMetadata& m : kept_metadata_) write_metadata_record(m.name, m.values);
  for (const KeptAttachment& a : kept_attachments_)
    write_attachment_record(a.name, a.media_type, a.log_time, a.create_time, a.data);
}

McapWriter::~McapWriter() {
  try {
    close();
  } catch (...) {
    // close() reports errors to callers that call it; a destructor must not throw.
  }
  if (file_ != nullptr) std::fclose(file_);
  ZSTD_freeCCtx(static_cast<ZSTD_CCtx*>(zstd_ctx_));
}

void McapWriter::check_open(const char* what) const {
  if (file_ == nullptr)
    throw std::logic_error(std::string("McapWriter::") + what + ": " + path_.string() + " is closed");
}

void McapWriter::io_error(const char* what) const {
  const int err = errno;
  throw std::runtime_error(path_.string() + ": " + what + " at byte " + std::to_string(offset_) + ": " +
                           std::strerror(err));
}

void McapWriter::write_out(const void* data, std::size_t size, bool update_crc) {
  if (size == 0) return;
  if (std::fwrite(data, 1, size, file_) != size) {
    const int err = errno;
    std::fclose(file_);
    file_ = nullptr;
    errno = err;
    io_error("write failed");
  }
  if (update_crc && in_data_section_ && options_.data_section_crc) data_crc_ = crc32_update(data_crc_, data, size);
  offset_ += size;
  stats_.file_bytes = bytes_before_ + offset_;
}

void McapWriter::write_record(const std::vector<std::uint8_t>& record) {
  write_out(record.data(), record.size());
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding,
                                     std::span<const std::uint8_t> data) {
  check_open("add_schema");
  if (schemas_.size() >= std::numeric_limits<std::uint16_t>::max())
    throw std::length_error(path_.string() + ": more than 65535 schemas");
  Schema s;
  s.id = static_cast<std::uint16_t>(schemas_.size() + 1);
  s.name = name;
  s.encoding = encoding;
  s.data.assign(data.begin(), data.end());
  scratch_.clear();
  append_schema(scratch_, s);
  write_record(scratch_);
  schemas_.push_back(std::move(s));
  return schemas_.back().id;
}

std::uint16_t McapWriter::add_schema(const std::string& name, const std::string& encoding, const std::string& data) {
  return add_schema(name, encoding,
                    std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(data.data()), data.size()));
}

std::uint16_t McapWriter::add_channel(std::uint16_t schema_id, const std::string& topic,
                                      const std::string& message_encoding,
                                      const std::map<std::string, std::string>& metadata) {
  check_open("add_channel");
  if (schema_id > schemas_.size())
    throw std::invalid_argument("McapWriter::add_channel: unknown schema id " + std::to_string(schema_id) +
                                " for topic '" + topic + "'");
  if (channels_.size() >= std::numeric_limits<std::uint16_t>::max())
    throw std::length_error(path_.string() + ": more than 65535 channels");
  Channel c;
  c.id = static_cast<std::uint16_t>(channels_.size() + 1);
  c.schema_id = schema_id;
  c.topic = topic;
  c.message_encoding = message_encoding;
  c.metadata = metadata;
  // The ros2 profile requires the key (the publisher's QoS as YAML); "" when the caller has none.
  if (options_.profile == "ros2") c.metadata.try_emplace("offered_qos_profiles", "");
  scratch_.clear();
  append_channel(scratch_, c);
  write_record(scratch_);
  channels_.push_back(std::move(c));
  chunk_index_.resize(channels_.size() + 1);
  return channels_.back().id;
}

void McapWriter::write(std::uint16_t channel_id, std::uint32_t sequence, std::uint64_t log_time_ns,
                       std::uint64_t publish_time_ns, std::span<const std::uint8_t> data) {
  check_open("write");
  if (channel_id == 0 || channel_id > channels_.size())
    throw std::invalid_argument("McapWriter::write: unknown channel id " + std::to_string(channel_id));
  if (file_messages_ > 0 &&
      ((options_.split_bytes > 0 && offset_ + chunk_.size() >= options_.split_bytes) ||
       (options_.split_duration_ns > 0 && log_time_ns >= message_start_ + options_.split_duration_ns)))
    start_next_file();
  auto& index = chunk_index_[channel_id];
  if (index.empty()) chunk_channels_.push_back(channel_id);
  index.push_back(log_time_ns);
  index.push_back(chunk_.size());
  chunk_.push_back(static_cast<std::uint8_t>(Opcode::kMessage));
  put_u64(chunk_, 2 + 4 + 8 + 8 + data.size());
  put_u16(chunk_, channel_id);
  put_u32(chunk_, sequence);
  put_u64(chunk_, log_time_ns);
  put_u64(chunk_, publish_time_ns);
  put_bytes(chunk_, data.data(), data.size());

  if (chunk_messages_ == 0 || log_time_ns < chunk_start_) chunk_start_ = log_time_ns;
  if (chunk_messages_ == 0 || log_time_ns > chunk_end_) chunk_end_ = log_time_ns;
  if (file_messages_ == 0 || log_time_ns < message_start_) message_start_ = log_time_ns;
  if (file_messages_ == 0 || log_time_ns > message_end_) message_end_ = log_time_ns;
  ++chunk_messages_;
  ++file_messages_;
  ++stats_.messages;
  stats_.message_bytes += data.size();
  ++channel_counts_[channel_id];
  if (chunk_.size() >= options_.chunk_size) write_chunk();
}

void McapWriter::write_chunk() {
  if (chunk_.empty()) return;
  const std::uint32_t crc = options_.chunk_crc ? crc32(chunk_.data(), chunk_.size()) : 0U;
  const std::uint8_t* records = chunk_.data();
  std::size_t records_size = chunk_.size();
  if (options_.compression == Compression::kZstd) {
    compressed_.resize(ZSTD_compressBound(chunk_.size()));
    const std::size_t n = ZSTD_compressCCtx(static_cast<ZSTD_CCtx*>(zstd_ctx_), compressed_.data(), compressed_.size(),
                                            chunk_.data(), chunk_.size(), options_.zstd_level);
    if (ZSTD_isError(n) != 0)
      throw std::runtime_error(path_.string() + ": zstd compression failed at byte " + std::to_string(offset_) + ": " +
                               ZSTD_getErrorName(n));
    records = compressed_.data();
    records_size = n;
  }
  const char* compression = compression_name(options_.compression);
  ChunkIndexEntry entry;
  entry.info.offset = offset_;
  entry.info.message_start_time = chunk_messages_ > 0 ? chunk_start_ : 0;
  entry.info.message_end_time = chunk_messages_ > 0 ? chunk_end_ : 0;
  entry.info.compression = compression;
  entry.info.compressed_size = records_size;
  entry.info.uncompressed_size = chunk_.size();

  scratch_.clear();
  scratch_.push_back(static_cast<std::uint8_t>(Opcode::kChunk));
  const std::uint64_t content = 8 + 8 + 8 + 4 + 4 + std::strlen(compression) + 8 + records_size;
  put_u64(scratch_, content);
  put_u64(scratch_, entry.info.message_start_time);
  put_u64(scratch_, entry.info.message_end_time);
  put_u64(scratch_, chunk_.size());
  put_u32(scratch_, crc);
  put_string(scratch_, compression);
  put_u64(scratch_, records_size);
  write_record(scratch_);
  if (options_.compression == Compression::kNone && options_.chunk_crc && in_data_section_ &&
      options_.data_section_crc) {
    // The records' CRC is known: fold it into the data-section CRC instead of a second pass.
    write_out(records, records_size, false);
    data_crc_ = crc32_combine(data_crc_, crc, records_size);
  } else {
    write_out(records, records_size);
  }
  entry.info.length = 1 + 8 + content;

  // One Message Index per channel of the chunk, in channel id order, entries in log-time order.
  std::sort(chunk_channels_.begin(), chunk_channels_.end());
  const std::uint64_t index_start = offset_;
  for (const std::uint16_t id : chunk_channels_) {
    auto& index = chunk_index_[id];
    const std::size_t n = index.size() / 2;
    bool sorted = true;
    for (std::size_t i = 1; i < n && sorted; ++i) sorted = index[2 * i] >= index[2 * i - 2];
    if (!sorted) {
      std::vector<std::pair<std::uint64_t, std::uint64_t>> pairs(n);
      for (std::size_t i = 0; i < n; ++i) pairs[i] = {index[2 * i], index[2 * i + 1]};
      std::stable_sort(pairs.begin(), pairs.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
      for (std::size_t i = 0; i < n; ++i) {
        index[2 * i] = pairs[i].first;
        index[2 * i + 1] = pairs[i].second;
      }
    }
    entry.message_index_offsets[id] = offset_;
    scratch_.clear();
    const std::size_t at = begin_record(scratch_, static_cast<std::uint8_t>(Opcode::kMessageIndex));
    put_u16(scratch_, id);
    put_u32(scratch_, static_cast<std::uint32_t>(index.size() * 8));
    for (const std::uint64_t v : index) put_u64(scratch_, v);
    end_record(scratch_, at);
    write_record(scratch_);
    index.clear();
  }
  entry.message_index_length = offset_ - index_start;
  chunk_indexes_.push_back(std::move(entry));
  chunk_channels_.clear();
  chunk_.clear();
  chunk_messages_ = 0;
  ++stats_.chunks;
}

void McapWriter::add_metadata(const std::string& name, const std::map<std::string, std::string>& values) {
  check_open("add_metadata");
  write_metadata_record(name, values);
  kept_metadata_.push_back({name, values});
}

void McapWriter::add_attachment(const std::string& name, const std::string& media_type, std::uint64_t log_time_ns,
                                std::uint64_t create_time_ns, std::span<const std::uint8_t> data) {
  check_open("add_attachment");
  write_attachment_record(name, media_type, log_time_ns, create_time_ns, data);
  kept_attachments_.push_back({name, media_type, log_time_ns, create_time_ns, {data.begin(), data.end()}});
}

void McapWriter::write_metadata_record(const std::string& name, const std::map<std::string, std::string>& values) {
  MetadataIndexEntry e;
  e.offset = offset_;
  e.name = name;
  scratch_.clear();
  const std::size_t at = begin_record(scratch_, static_cast<std::uint8_t>(Opcode::kMetadata));
  put_string(scratch_, name);
  put_string_map(scratch_, values);
  end_record(scratch_, at);
  e.length = scratch_.size();
  write_record(scratch_);
  metadata_indexes_.push_back(std::move(e));
}

void McapWriter::write_attachment_record(const std::string& name, const std::string& media_type,
                                         std::uint64_t log_time_ns, std::uint64_t create_time_ns,
                                         std::span<const std::uint8_t> data) {
  AttachmentIndexEntry e;
  e.info.offset = offset_;
  e.info.log_time = log_time_ns;
  e.info.create_time = create_time_ns;
  e.info.name = name;
  e.info.media_type = media_type;
  e.info.data_size = data.size();
  scratch_.clear();
  const std::size_t at = begin_record(scratch_, static_cast<std::uint8_t>(Opcode::kAttachment));
  put_u64(scratch_, log_time_ns);
  put_u64(scratch_, create_time_ns);
  put_string(scratch_, name);
  put_string(scratch_, media_type);
  put_u64(scratch_, data.size());
  put_bytes(scratch_, data.data(), data.size());
  // The CRC covers the record's fields before it (not the opcode and length).
  put_u32(scratch_, crc32(scratch_.data() + at + 8, scratch_.size() - at - 8));
  end_record(scratch_, at);
  e.length = scratch_.size();
  write_record(scratch_);
  attachment_indexes_.push_back(std::move(e));
}

void McapWriter::flush() {
  check_open("flush");
  write_chunk();
  if (std::fflush(file_) != 0) io_error("flush failed");
}

void McapWriter::close() {
  if (file_ == nullptr) return;
  finish_file();
}

void McapWriter::finish_file() {
  write_chunk();

  // DataEnd: CRC of every byte before it.
  scratch_.clear();
  std::size_t at = begin_record(scratch_, static_cast<std::uint8_t>(Opcode::kDataEnd));
  put_u32(scratch_, options_.data_section_crc ? data_crc_ : 0U);
  end_record(scratch_, at);
  in_data_section_ = false;
  write_record(scratch_);

  // Summary section, grouped by opcode; then one Summary Offset per group; then the Footer.
  const std::uint64_t summary_start = offset_;
  std::vector<std::uint8_t> s;
  struct Group {
    std::uint8_t op;
    std::uint64_t start, length;
  };
  std::vector<Group> groups;
  auto group = [&](Opcode op, auto&& body) {
    const std::size_t begin = s.size();
    body();
    if (s.size() > begin) groups.push_back({static_cast<std::uint8_t>(op), summary_start + begin, s.size() - begin});
  };
  group(Opcode::kSchema, [&] {
    for (const auto& sc : schemas_) append_schema(s, sc);
  });
  group(Opcode::kChannel, [&] {
    for (const auto& c : channels_) append_channel(s, c);
  });
  group(Opcode::kStatistics, [&] {
    at = begin_record(s, static_cast<std::uint8_t>(Opcode::kStatistics));
    put_u64(s, file_messages_);
    put_u16(s, static_cast<std::uint16_t>(schemas_.size()));
    put_u32(s, static_cast<std::uint32_t>(channels_.size()));
    put_u32(s, static_cast<std::uint32_t>(attachment_indexes_.size()));
    put_u32(s, static_cast<std::uint32_t>(metadata_indexes_.size()));
    put_u32(s, static_cast<std::uint32_t>(chunk_indexes_.size()));
    put_u64(s, file_messages_ > 0 ? message_start_ : 0);
    put_u64(s, file_messages_ > 0 ? message_end_ : 0);
    put_u32(s, static_cast<std::uint32_t>(channel_counts_.size() * 10));
    for (const auto& [id, n] : channel_counts_) {
      put_u16(s, id);
      put_u64(s, n);
    }
    end_record(s, at);
  });
  group(Opcode::kChunkIndex, [&] {
    for (const auto& e : chunk_indexes_) {
      at = begin_record(s, static_cast<std::uint8_t>(Opcode::kChunkIndex));
      put_u64(s, e.info.message_start_time);
      put_u64(s, e.info.message_end_time);
      put_u64(s, e.info.offset);
      put_u64(s, e.info.length);
      put_u32(s, static_cast<std::uint32_t>(e.message_index_offsets.size() * 10));
      for (const auto& [id, off] : e.message_index_offsets) {
        put_u16(s, id);
        put_u64(s, off);
      }
      put_u64(s, e.message_index_length);
      put_string(s, e.info.compression);
      put_u64(s, e.info.compressed_size);
      put_u64(s, e.info.uncompressed_size);
      end_record(s, at);
    }
  });
  group(Opcode::kAttachmentIndex, [&] {
    for (const auto& e : attachment_indexes_) {
      at = begin_record(s, static_cast<std::uint8_t>(Opcode::kAttachmentIndex));
      put_u64(s, e.info.offset);
      put_u64(s, e.length);
      put_u64(s, e.info.log_time);
      put_u64(s, e.info.create_time);
      put_u64(s, e.info.data_size);
      put_string(s, e.info.name);
      put_string(s, e.info.media_type);
      end_record(s, at);
    }
  });
  group(Opcode::kMetadataIndex, [&] {
    for (const auto& e : metadata_indexes_) {
      at = begin_record(s, static_cast<std::uint8_t>(Opcode::kMetadataIndex));
      put_u64(s, e.offset);
      put_u64(s, e.length);
      put_string(s, e.name);
      end_record(s, at);
    }
  });
  const std::uint64_t summary_offset_start = summary_start + s.size();
  for (const auto& g : groups) {
    at = begin_record(s, static_cast<std::uint8_t>(Opcode::kSummaryOffset));
    put_u8(s, g.op);
    put_u64(s, g.start);
    put_u64(s, g.length);
    end_record(s, at);
  }
  put_u8(s, static_cast<std::uint8_t>(Opcode::kFooter));
  put_u64(s, 8 + 8 + 4);  // the length first: it is covered by the CRC
  put_u64(s, summary_start);
  put_u64(s, summary_offset_start);
  // The summary CRC covers the summary, the summary offsets and the footer up to this field.
  put_u32(s, options_.summary_crc ? crc32(s.data(), s.size()) : 0U);
  put_bytes(s, kMcapMagic.data(), kMcapMagic.size());
  write_out(s.data(), s.size());
  std::FILE* f = file_;
  file_ = nullptr;
  bytes_before_ += offset_;
  if (std::fclose(f) != 0) io_error("close failed");
}

}  // namespace regolith::record
