// McapReader: see mcap_reader.hpp; record layouts from the MCAP specification (mcap.dev/spec).
#include "regolith/record/mcap_reader.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <stdexcept>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>
#include <zstd.h>

#include "bytes.hpp"
#include "regolith/core/error.hpp"
#include "regolith/record/crc32.hpp"
#include "regolith/record/mcap_writer.hpp"

namespace regolith::record {

using namespace detail;

namespace {

constexpr std::uint64_t kRecordPrefix = 9;   // opcode + uint64 length
constexpr std::uint64_t kFooterRecord = 29;  // prefix + 8 + 8 + 4

/// A record field that runs past its record (or a value that makes no sense): caught per record.
struct Malformed : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// Bounds-checked little-endian reading of one record's content.
class Cursor {
 public:
  Cursor(const std::uint8_t* p, std::uint64_t n) : p_(p), n_(n) {}
  std::uint8_t u8() { return *take(1); }
  std::uint16_t u16() { return get_u16(take(2)); }
  std::uint32_t u32() { return get_u32(take(4)); }
  std::uint64_t u64() { return get_u64(take(8)); }
  std::string string(const char* field) {
    const std::uint32_t len = u32();
    if (len > n_ - pos_)
      throw Malformed(std::string(field) + ": length " + std::to_string(len) + " runs past the record");
    const auto* s = take(len);
    return std::string(reinterpret_cast<const char*>(s), len);
  }
  std::span<const std::uint8_t> bytes(std::uint64_t len, const char* field) {
    if (len > n_ - pos_)
      throw Malformed(std::string(field) + ": length " + std::to_string(len) + " runs past the record");
    return {take(len), static_cast<std::size_t>(len)};
  }
  std::map<std::string, std::string> string_map(const char* field) {
    const std::uint32_t len = u32();
    if (len > n_ - pos_)
      throw Malformed(std::string(field) + ": length " + std::to_string(len) + " runs past the record");
    Cursor inner(take(len), len);
    std::map<std::string, std::string> m;
    while (inner.remaining() > 0) {
      std::string k = inner.string(field);
      m[std::move(k)] = inner.string(field);
    }
    return m;
  }
  /// Map<uint16, uint64> (channel id -> count or offset).
  std::map<std::uint16_t, std::uint64_t> id_map(const char* field) {
    const std::uint32_t len = u32();
    if (len > n_ - pos_ || len % 10 != 0)
      throw Malformed(std::string(field) + ": bad byte length " + std::to_string(len));
    Cursor inner(take(len), len);
    std::map<std::uint16_t, std::uint64_t> m;
    while (inner.remaining() > 0) {
      const std::uint16_t k = inner.u16();
      m[k] = inner.u64();
    }
    return m;
  }
  std::uint64_t remaining() const { return n_ - pos_; }
  std::uint64_t pos() const { return pos_; }

 private:
  const std::uint8_t* take(std::uint64_t k) {
    if (k > n_ - pos_) throw Malformed("record too short (" + std::to_string(n_) + " bytes)");
    const std::uint8_t* r = p_ + pos_;
    pos_ += k;
    return r;
  }
  const std::uint8_t* p_;
  std::uint64_t n_;
  std::uint64_t pos_ = 0;
};

// A Schema record into `info` (id 0 is reserved for "no schema" and is not stored).
void add_schema(Cursor& c, McapFileInfo& info) {
  Schema s;
  s.id = c.u16();
  s.name = c.string("name");
  s.encoding = c.string("encoding");
  const std::uint32_t n = c.u32();
  const auto d = c.bytes(n, "data");
  s.data.assign(d.begin(), d.end());
  if (s.id != 0) info.schemas[s.id] = std::move(s);
}

// A Channel record into `info`.
void add_channel(Cursor& c, McapFileInfo& info) {
  Channel ch;
  ch.id = c.u16();
  ch.schema_id = c.u16();
  ch.topic = c.string("topic");
  ch.message_encoding = c.string("message_encoding");
  ch.metadata = c.string_map("metadata");
  info.channels[ch.id] = std::move(ch);
}

// A Metadata record's name and values.
Metadata read_metadata_record(Cursor& c) {
  Metadata m;
  m.name = c.string("name");
  m.values = c.string_map("metadata");
  return m;
}

// One message into the counts, first and last log time of `info` (the counting pass of a scan,
// in or outside chunks).
void count_message(McapFileInfo& info, std::uint16_t channel_id, std::uint64_t log_time) {
  if (info.message_count == 0 || log_time < info.message_start_time) info.message_start_time = log_time;
  if (info.message_count == 0 || log_time > info.message_end_time) info.message_end_time = log_time;
  ++info.message_count;
  ++info.message_counts[channel_id];
}

std::string hex32(std::uint32_t v) {
  char b[16];
  std::snprintf(b, sizeof b, "0x%08x", v);
  return b;
}

// A DataEnd record: malformed, or (with `check_crc`) its stored CRC not `data_crc`, is a problem.
void check_data_end(std::uint64_t pos, const std::vector<std::uint8_t>& content, bool check_crc, std::uint32_t data_crc,
                    std::vector<ReadProblem>& problems) {
  try {
    Cursor c(content.data(), content.size());
    const std::uint32_t stored = c.u32();
    if (check_crc && stored != 0 && stored != data_crc)
      problems.push_back(
          {pos, "data section CRC mismatch (stored " + hex32(stored) + ", computed " + hex32(data_crc) + ")"});
  } catch (const Malformed& e) {
    problems.push_back({pos, std::string("bad DataEnd record: ") + e.what()});
  }
}

// An Attachment record found at `offset` (its data is not kept: read_attachment reads it again);
// with `verify_crc`, a stored CRC that does not match its bytes is Malformed.
AttachmentInfo read_attachment_record(Cursor& c, std::uint64_t offset, const std::vector<std::uint8_t>& content,
                                      bool verify_crc) {
  AttachmentInfo a;
  a.offset = offset;
  a.log_time = c.u64();
  a.create_time = c.u64();
  a.name = c.string("name");
  a.media_type = c.string("media_type");
  a.data_size = c.u64();
  c.bytes(a.data_size, "data");
  const std::uint64_t covered = c.pos();
  const std::uint32_t stored = c.u32();
  if (verify_crc && stored != 0) {
    const std::uint32_t crc = crc32(content.data(), static_cast<std::size_t>(covered));
    if (crc != stored)
      throw Malformed("attachment '" + a.name + "' CRC mismatch (stored " + hex32(stored) + ", computed " + hex32(crc) +
                      ")");
  }
  return a;
}

// One record of the summary section into `s` (a Metadata Index is kept in `metadata_at`: its
// record sits in the data section). Throws Malformed.
void add_summary_record(std::uint8_t op, Cursor& c, std::uint64_t data_start, McapFileInfo& s, bool& have_statistics,
                        std::vector<std::pair<std::uint64_t, std::uint64_t>>& metadata_at) {
  switch (static_cast<Opcode>(op)) {
    case Opcode::kSchema: add_schema(c, s); break;
    case Opcode::kChannel: add_channel(c, s); break;
    case Opcode::kStatistics: {
      s.message_count = c.u64();
      c.u16();  // schema count
      c.u32();  // channel count
      c.u32();  // attachment count
      c.u32();  // metadata count
      c.u32();  // chunk count
      s.message_start_time = c.u64();
      s.message_end_time = c.u64();
      s.message_counts = c.id_map("channel_message_counts");
      have_statistics = true;
      break;
    }
    case Opcode::kChunkIndex: {
      ChunkInfo ci;
      ci.message_start_time = c.u64();
      ci.message_end_time = c.u64();
      ci.offset = c.u64();
      ci.length = c.u64();
      c.id_map("message_index_offsets");
      c.u64();  // message_index_length
      ci.compression = c.string("compression");
      ci.compressed_size = c.u64();
      ci.uncompressed_size = c.u64();
      if (ci.offset < data_start || ci.offset > s.file_size || ci.length > s.file_size - ci.offset)
        throw Malformed("chunk at " + std::to_string(ci.offset) + " (+" + std::to_string(ci.length) +
                        " bytes) outside the file");
      s.chunks.push_back(std::move(ci));
      break;
    }
    case Opcode::kAttachmentIndex: {
      AttachmentInfo a;
      a.offset = c.u64();
      c.u64();  // length
      a.log_time = c.u64();
      a.create_time = c.u64();
      a.data_size = c.u64();
      a.name = c.string("name");
      a.media_type = c.string("media_type");
      s.attachments.push_back(std::move(a));
      break;
    }
    case Opcode::kMetadataIndex: {
      const std::uint64_t off = c.u64();
      const std::uint64_t mlen = c.u64();
      metadata_at.emplace_back(off, mlen);
      break;
    }
    default: break;  // DataEnd is not here; unknown and private records are skipped
  }
}

}  // namespace

// ---- byte sources -------------------------------------------------------------------------------
namespace detail {
class ByteSource {
 public:
  virtual ~ByteSource() = default;
  virtual std::uint64_t size() const = 0;
  /// Reads exactly n bytes at offset into dst; false on a short read or an I/O error.
  virtual bool read(std::uint64_t offset, std::uint64_t n, std::uint8_t* dst) = 0;
};
}  // namespace detail

namespace {

class FileSource final : public detail::ByteSource {
 public:
  FileSource(int fd, std::uint64_t size) : fd_(fd), size_(size) {}
  ~FileSource() override { ::close(fd_); }
  FileSource(const FileSource&) = delete;
  FileSource& operator=(const FileSource&) = delete;
  std::uint64_t size() const override { return size_; }
  bool read(std::uint64_t offset, std::uint64_t n, std::uint8_t* dst) override {
    if (offset > size_ || n > size_ - offset) return false;
    while (n > 0) {
      const ssize_t r =
          ::pread(fd_, dst, static_cast<std::size_t>(std::min<std::uint64_t>(n, 1U << 30)), static_cast<off_t>(offset));
      if (r < 0 && errno == EINTR) continue;
      if (r <= 0) return false;
      dst += r;
      offset += static_cast<std::uint64_t>(r);
      n -= static_cast<std::uint64_t>(r);
    }
    return true;
  }

 private:
  int fd_;
  std::uint64_t size_;
};

class MemorySource final : public detail::ByteSource {
 public:
  explicit MemorySource(std::vector<std::uint8_t> bytes) : bytes_(std::move(bytes)) {}
  std::uint64_t size() const override { return bytes_.size(); }
  bool read(std::uint64_t offset, std::uint64_t n, std::uint8_t* dst) override {
    if (offset > bytes_.size() || n > bytes_.size() - offset) return false;
    if (n > 0) std::memcpy(dst, bytes_.data() + offset, static_cast<std::size_t>(n));
    return true;
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

}  // namespace

// ---- opening ------------------------------------------------------------------------------------
McapReader::McapReader(const std::filesystem::path& path, McapReaderOptions options) : options_(options) {
  info_.name = path.string();
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) throw InputError(info_.name + ": cannot open: " + std::strerror(errno));
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    ::close(fd);
    throw InputError(info_.name + ": not a regular file");
  }
  source_ = std::make_unique<FileSource>(fd, static_cast<std::uint64_t>(st.st_size));
  open();
}

McapReader::McapReader(std::vector<std::uint8_t> bytes, std::string name, McapReaderOptions options)
    : source_(std::make_unique<MemorySource>(std::move(bytes))), options_(options) {
  info_.name = std::move(name);
  open();
}

McapReader::~McapReader() = default;

std::string McapReader::describe(const ReadProblem& p) const {
  return info_.name + ": byte " + std::to_string(p.offset) + ": " + p.what;
}

void McapReader::fail(std::uint64_t offset, const std::string& what) const {
  throw InputError(describe({offset, what}));
}

void McapReader::open() {
  info_.file_size = source_->size();
  const std::uint64_t size = info_.file_size;
  std::uint8_t magic[8] = {};
  if (size < kMcapMagic.size())
    fail(0, "not an MCAP file: " + std::to_string(size) + " bytes, shorter than the 8-byte magic");
  if (!source_->read(0, 8, magic)) fail(0, "read error");
  if (std::memcmp(magic, kMcapMagic.data(), 8) != 0) {
    std::string got;
    for (const std::uint8_t b : magic) {
      char h[4];
      std::snprintf(h, sizeof h, "%02x ", b);
      got += h;
    }
    fail(0, "not an MCAP file: wrong magic " + got + "(expected 89 4d 43 41 50 30 0d 0a)");
  }
  // The Header record must follow the magic.
  std::uint8_t prefix[kRecordPrefix];
  if (size < 8 + kRecordPrefix || !source_->read(8, kRecordPrefix, prefix)) {
    info_.truncated = true;
    info_.readable_end = 8;
    fail(8, "truncated before the Header record");
  }
  if (prefix[0] != static_cast<std::uint8_t>(Opcode::kHeader))
    fail(8, "expected a Header record after the magic, found " + opcode_name(prefix[0]));
  const std::uint64_t len = get_u64(prefix + 1);
  if (len > size - 8 - kRecordPrefix) fail(8, "truncated inside the Header record");
  if (len > (1U << 20)) fail(8, "Header record of " + std::to_string(len) + " bytes");
  std::vector<std::uint8_t> content(static_cast<std::size_t>(len));
  if (!source_->read(8 + kRecordPrefix, len, content.data())) fail(8, "read error");
  try {
    Cursor c(content.data(), len);
    info_.profile = c.string("profile");
    info_.library = c.string("library");
  } catch (const Malformed& e) {
    fail(8, std::string("bad Header record: ") + e.what());
  }
  data_start_ = 8 + kRecordPrefix + len;

  if (options_.use_summary && read_summary()) return;
  McapFileInfo scanned;
  scanned.name = info_.name;
  scanned.file_size = info_.file_size;
  scanned.profile = info_.profile;
  scanned.library = info_.library;
  scanned.problems = std::move(info_.problems);  // a summary problem found on the way
  std::vector<ReadProblem> problems;
  scan(scanned, nullptr, problems);
  scanned.problems.insert(scanned.problems.end(), problems.begin(), problems.end());
  info_ = std::move(scanned);
}

// ---- the fast path: Footer + summary ------------------------------------------------------------
bool McapReader::read_summary() {
  const std::uint64_t size = info_.file_size;
  if (size < data_start_ + kFooterRecord + 8) return false;
  const std::uint64_t footer_at = size - 8 - kFooterRecord;
  std::uint8_t tail[kFooterRecord + 8];
  if (!source_->read(footer_at, sizeof tail, tail)) return false;
  if (std::memcmp(tail + kFooterRecord, kMcapMagic.data(), 8) != 0) return false;  // no end magic: cut off
  if (tail[0] != static_cast<std::uint8_t>(Opcode::kFooter) || get_u64(tail + 1) != 20) return false;
  const std::uint64_t summary_start = get_u64(tail + 9);
  const std::uint64_t summary_offset_start = get_u64(tail + 17);
  const std::uint32_t summary_crc = get_u32(tail + 25);
  if (summary_start == 0) return false;  // no summary
  if (summary_start < data_start_ || summary_start > footer_at ||
      (summary_offset_start != 0 && (summary_offset_start < summary_start || summary_offset_start > footer_at))) {
    info_.problems.push_back({footer_at, "Footer: summary offsets " + std::to_string(summary_start) + " / " +
                                             std::to_string(summary_offset_start) + " outside the file; scanning"});
    return false;
  }
  const std::uint64_t summary_len = footer_at - summary_start;
  if (summary_len > options_.max_record_bytes) return false;
  std::vector<std::uint8_t> summary(static_cast<std::size_t>(summary_len + kRecordPrefix + 16));
  if (!source_->read(summary_start, summary.size(), summary.data())) return false;
  if (options_.verify_crcs && summary_crc != 0) {
    const std::uint32_t crc = crc32(summary.data(), summary.size());
    if (crc != summary_crc) {
      info_.problems.push_back({summary_start, "summary CRC mismatch (stored " + hex32(summary_crc) + ", computed " +
                                                   hex32(crc) + "); scanning the data section instead"});
      return false;
    }
  }
  McapFileInfo s;
  s.name = info_.name;
  s.file_size = size;
  s.profile = info_.profile;
  s.library = info_.library;
  s.from_summary = true;
  bool have_statistics = false;
  const std::uint64_t end = (summary_offset_start != 0 ? summary_offset_start : footer_at) - summary_start;
  std::uint64_t pos = 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> metadata_at;  // offset, length
  while (pos < end) {
    const std::uint64_t record_at = summary_start + pos;
    if (end - pos < kRecordPrefix) {
      info_.problems.push_back({record_at, "summary: record prefix runs past the summary; scanning"});
      return false;
    }
    const std::uint8_t op = summary[pos];
    const std::uint64_t len = get_u64(summary.data() + pos + 1);
    if (len > end - pos - kRecordPrefix) {
      info_.problems.push_back({record_at, "summary: " + opcode_name(op) + " record runs past the summary; scanning"});
      return false;
    }
    Cursor c(summary.data() + pos + kRecordPrefix, len);
    try {
      add_summary_record(op, c, data_start_, s, have_statistics, metadata_at);
    } catch (const Malformed& e) {
      info_.problems.push_back({record_at, "summary: bad " + opcode_name(op) + " record: " + e.what() + "; scanning"});
      return false;
    }
    pos += kRecordPrefix + len;
  }
  // Without Statistics, or with messages but no Chunk Index (messages outside chunks, which only
  // a scan finds), the summary is not enough.
  if (!have_statistics || (s.message_count > 0 && s.chunks.empty())) return false;
  std::sort(s.chunks.begin(), s.chunks.end(),
            [](const ChunkInfo& a, const ChunkInfo& b) { return a.offset < b.offset; });
  read_metadata(metadata_at, s);
  s.problems.insert(s.problems.begin(), info_.problems.begin(), info_.problems.end());
  info_ = std::move(s);
  return true;
}

void McapReader::read_metadata(const std::vector<std::pair<std::uint64_t, std::uint64_t>>& metadata_at,
                               McapFileInfo& s) {
  const std::uint64_t size = s.file_size;
  for (const auto& [off, mlen] : metadata_at) {
    std::vector<std::uint8_t> rec;
    if (mlen < kRecordPrefix || mlen > options_.max_record_bytes || off > size || mlen > size - off) {
      s.problems.push_back({off, "Metadata record outside the file"});
      continue;
    }
    rec.resize(static_cast<std::size_t>(mlen));
    if (!source_->read(off, mlen, rec.data()) || rec[0] != static_cast<std::uint8_t>(Opcode::kMetadata) ||
        get_u64(rec.data() + 1) != mlen - kRecordPrefix) {
      s.problems.push_back({off, "no Metadata record where the summary says"});
      continue;
    }
    try {
      Cursor c(rec.data() + kRecordPrefix, mlen - kRecordPrefix);
      s.metadata.push_back(read_metadata_record(c));
    } catch (const Malformed& e) {
      s.problems.push_back({off, std::string("bad Metadata record: ") + e.what()});
    }
  }
}

// ---- the slow path: every record of the data section --------------------------------------------
void McapReader::scan(McapFileInfo& info, const Emit* emit, std::vector<ReadProblem>& problems) {
  const bool crc_on = options_.verify_crcs;
  std::uint32_t data_crc = 0;
  std::vector<std::uint8_t> content;
  if (crc_on) {  // the magic and the Header are part of the data-section CRC
    content.resize(static_cast<std::size_t>(data_start_));
    if (source_->read(0, data_start_, content.data())) data_crc = crc32(content.data(), content.size());
  }
  std::uint8_t prefix[kRecordPrefix];
  for (std::uint64_t pos = data_start_; !stop_; pos += kRecordPrefix + content.size()) {
    if (!read_data_record(pos, info, prefix, content, problems)) return;
    if (prefix[0] == static_cast<std::uint8_t>(Opcode::kDataEnd)) {
      check_data_end(pos, content, emit == nullptr && crc_on, data_crc, problems);
      // The data section is complete; the file is truncated if the Footer and end magic are missing.
      std::uint8_t tail[8];
      const bool has_end = info.file_size >= data_start_ + kFooterRecord + 8 &&
                           source_->read(info.file_size - 8, 8, tail) && std::memcmp(tail, kMcapMagic.data(), 8) == 0;
      info.truncated = !has_end;
      info.readable_end = has_end ? info.file_size : pos;
      return;
    }
    if (crc_on) {
      data_crc = crc32_update(data_crc, prefix, kRecordPrefix);
      data_crc = crc32_update(data_crc, content.data(), content.size());
    }
    scan_record(pos, prefix[0], content, info, emit, problems);
  }
}

bool McapReader::read_data_record(std::uint64_t pos, McapFileInfo& info, std::uint8_t* prefix,
                                  std::vector<std::uint8_t>& content, std::vector<ReadProblem>& problems) {
  const std::uint64_t size = info.file_size;
  // A clean end of a record but no DataEnd / Footer, or a record cut off: the file is truncated.
  if (pos == size || size - pos < kRecordPrefix || !source_->read(pos, kRecordPrefix, prefix) ||
      get_u64(prefix + 1) > size - pos - kRecordPrefix) {
    info.truncated = true;
    info.readable_end = pos;
    return false;
  }
  const std::uint8_t op = prefix[0];
  const std::uint64_t len = get_u64(prefix + 1);
  auto stop = [&](std::string what) {
    problems.push_back({pos, std::move(what)});
    info.readable_end = pos;
    return false;
  };
  if (op == 0 || op == static_cast<std::uint8_t>(Opcode::kFooter) || op == static_cast<std::uint8_t>(Opcode::kHeader))
    return stop("unexpected " + (op == 0 ? std::string("opcode 0x00") : opcode_name(op)) +
                " record in the data section; cannot read further");
  if (len > options_.max_record_bytes)
    return stop(opcode_name(op) + " record of " + std::to_string(len) + " bytes exceeds the limit of " +
                std::to_string(options_.max_record_bytes) + "; cannot read further");
  content.resize(static_cast<std::size_t>(len));
  if (!source_->read(pos + kRecordPrefix, len, content.data())) return stop("read error");
  return true;
}

void McapReader::scan_record(std::uint64_t pos, std::uint8_t op, const std::vector<std::uint8_t>& content,
                             McapFileInfo& info, const Emit* emit, std::vector<ReadProblem>& problems) {
  const bool count = emit == nullptr;
  Cursor c(content.data(), content.size());
  try {
    switch (static_cast<Opcode>(op)) {
      case Opcode::kSchema: add_schema(c, info); break;
      case Opcode::kChannel: add_channel(c, info); break;
      case Opcode::kMessage: {
        const std::uint16_t id = c.u16();
        const std::uint32_t seq = c.u32();
        const std::uint64_t log_time = c.u64();
        const std::uint64_t publish_time = c.u64();
        const auto data = c.bytes(c.remaining(), "data");
        const auto ch = info.channels.find(id);
        if (ch == info.channels.end()) throw Malformed("message on unknown channel id " + std::to_string(id));
        if (count)
          count_message(info, id, log_time);
        else
          (*emit)(MessageView{ch->second, seq, log_time, publish_time, data});
        break;
      }
      case Opcode::kChunk: process_chunk(pos, content, info, emit, count, problems); break;
      case Opcode::kAttachment:
        if (count) info.attachments.push_back(read_attachment_record(c, pos, content, options_.verify_crcs));
        break;
      case Opcode::kMetadata:
        if (count) info.metadata.push_back(read_metadata_record(c));
        break;
      default: break;  // Message Index (rebuilt from the chunks), summary-only records, private records
    }
  } catch (const Malformed& e) {
    problems.push_back({pos, opcode_name(op) + " record: " + e.what()});
  }
}

bool McapReader::process_chunk(std::uint64_t offset, const std::vector<std::uint8_t>& content, McapFileInfo& info,
                               const Emit* emit, bool count, std::vector<ReadProblem>& problems) {
  ChunkInfo ci;
  ci.offset = offset;
  ci.length = kRecordPrefix + content.size();
  std::span<const std::uint8_t> records;
  std::uint32_t stored_crc = 0;
  try {
    Cursor c(content.data(), content.size());
    ci.message_start_time = c.u64();
    ci.message_end_time = c.u64();
    ci.uncompressed_size = c.u64();
    stored_crc = c.u32();
    ci.compression = c.string("compression");
    ci.compressed_size = c.u64();
    records = c.bytes(ci.compressed_size, "records");
  } catch (const Malformed& e) {
    problems.push_back({offset, std::string("Chunk record: ") + e.what()});
    return false;
  }
  auto bad = [&](const std::string& what) {
    problems.push_back({offset, "Chunk: " + what + "; its messages are skipped"});
    return false;
  };
  if (ci.uncompressed_size > options_.max_record_bytes)
    return bad("uncompressed size " + std::to_string(ci.uncompressed_size) + " exceeds the limit");
  const std::uint8_t* data = records.data();
  if (ci.compression.empty()) {
    if (ci.uncompressed_size != records.size())
      return bad("uncompressed size " + std::to_string(ci.uncompressed_size) + " != records size " +
                 std::to_string(records.size()));
  } else if (ci.compression == "zstd") {
    const unsigned long long frame = ZSTD_getFrameContentSize(records.data(), records.size());
    if (frame == ZSTD_CONTENTSIZE_ERROR) return bad("not a zstd frame");
    if (frame != ZSTD_CONTENTSIZE_UNKNOWN && frame != ci.uncompressed_size)
      return bad("zstd frame of " + std::to_string(frame) + " bytes, chunk says " +
                 std::to_string(ci.uncompressed_size));
    chunk_buffer_.resize(static_cast<std::size_t>(ci.uncompressed_size));
    const std::size_t n = ZSTD_decompress(chunk_buffer_.data(), chunk_buffer_.size(), records.data(), records.size());
    if (ZSTD_isError(n) != 0) return bad(std::string("zstd: ") + ZSTD_getErrorName(n));
    if (n != ci.uncompressed_size)
      return bad("decompressed to " + std::to_string(n) + " bytes, chunk says " + std::to_string(ci.uncompressed_size));
    data = chunk_buffer_.data();
  } else {
    return bad("compression '" + ci.compression + "' is not supported (zstd and none are)");
  }
  const std::uint64_t n = ci.uncompressed_size;
  if (options_.verify_crcs && stored_crc != 0) {
    const std::uint32_t crc = crc32(data, static_cast<std::size_t>(n));
    if (crc != stored_crc) return bad("CRC mismatch (stored " + hex32(stored_crc) + ", computed " + hex32(crc) + ")");
  }
  // The records of the chunk: Schema and Channel are registered, Messages collected and emitted in
  // log-time order.
  struct Entry {
    std::uint64_t log_time;
    std::uint64_t at;  // offset of the message content in `data`
    std::uint64_t len;
  };
  std::vector<Entry> messages;
  std::uint64_t pos = 0;
  while (pos < n) {
    try {
      if (n - pos < kRecordPrefix) throw Malformed("record prefix runs past the chunk");
      const std::uint8_t op = data[pos];
      const std::uint64_t len = get_u64(data + pos + 1);
      if (len > n - pos - kRecordPrefix) throw Malformed(opcode_name(op) + " record runs past the chunk");
      Cursor c(data + pos + kRecordPrefix, len);
      if (op == static_cast<std::uint8_t>(Opcode::kMessage)) {
        c.u16();
        c.u32();
        const std::uint64_t log_time = c.u64();
        messages.push_back({log_time, pos + kRecordPrefix, len});
        if (len < 22) throw Malformed("Message record too short");
      } else if (op == static_cast<std::uint8_t>(Opcode::kSchema)) {
        add_schema(c, info);
      } else if (op == static_cast<std::uint8_t>(Opcode::kChannel)) {
        add_channel(c, info);
      }
      pos += kRecordPrefix + len;
    } catch (const Malformed& e) {
      problems.push_back({offset, "Chunk: record at +" + std::to_string(pos) + " of the uncompressed records: " +
                                      e.what() + "; the rest of the chunk is skipped"});
      break;
    }
  }
  std::stable_sort(messages.begin(), messages.end(),
                   [](const Entry& a, const Entry& b) { return a.log_time < b.log_time; });
  std::uint64_t unknown = 0;
  for (const Entry& m : messages) {
    if (stop_) break;
    const std::uint8_t* p = data + m.at;
    const std::uint16_t id = get_u16(p);
    const auto ch = info.channels.find(id);
    if (ch == info.channels.end()) {
      ++unknown;
      continue;
    }
    if (count) {
      count_message(info, id, m.log_time);
    } else {
      (*emit)(MessageView{ch->second, get_u32(p + 2), m.log_time, get_u64(p + 14),
                          std::span<const std::uint8_t>(p + 22, static_cast<std::size_t>(m.len - 22))});
    }
  }
  if (unknown > 0)
    problems.push_back({offset, "Chunk: " + std::to_string(unknown) + " messages on channels never defined; skipped"});
  if (count) info.chunks.push_back(std::move(ci));
  return true;
}

// ---- messages and attachments -------------------------------------------------------------------
std::vector<ReadProblem> McapReader::for_each_message(const std::function<void(const MessageView&)>& fn) {
  std::vector<ReadProblem> problems;
  stop_ = false;
  if (!info_.from_summary) {
    McapFileInfo scratch = info_;  // channels from the scan; nothing is counted again
    scan(scratch, &fn, problems);
    return problems;
  }
  std::vector<std::uint8_t> content;
  for (const ChunkInfo& ci : info_.chunks) {
    if (stop_) break;
    std::uint8_t prefix[kRecordPrefix];
    if (ci.length < kRecordPrefix || !source_->read(ci.offset, kRecordPrefix, prefix) ||
        prefix[0] != static_cast<std::uint8_t>(Opcode::kChunk) || get_u64(prefix + 1) != ci.length - kRecordPrefix) {
      problems.push_back({ci.offset, "no Chunk record where the chunk index says; skipped"});
      continue;
    }
    if (ci.length - kRecordPrefix > options_.max_record_bytes) {
      problems.push_back({ci.offset, "Chunk record exceeds the size limit; skipped"});
      continue;
    }
    content.resize(static_cast<std::size_t>(ci.length - kRecordPrefix));
    if (!source_->read(ci.offset + kRecordPrefix, content.size(), content.data())) {
      problems.push_back({ci.offset, "read error"});
      continue;
    }
    McapFileInfo& info = info_;
    process_chunk(ci.offset, content, info, &fn, false, problems);
  }
  return problems;
}

std::vector<std::uint8_t> McapReader::read_attachment(const AttachmentInfo& a) {
  std::uint8_t prefix[kRecordPrefix];
  if (!source_->read(a.offset, kRecordPrefix, prefix) || prefix[0] != static_cast<std::uint8_t>(Opcode::kAttachment))
    fail(a.offset, "no Attachment record here");
  const std::uint64_t len = get_u64(prefix + 1);
  if (len > options_.max_record_bytes || len > info_.file_size) fail(a.offset, "Attachment record too large");
  std::vector<std::uint8_t> content(static_cast<std::size_t>(len));
  if (!source_->read(a.offset + kRecordPrefix, len, content.data()))
    fail(a.offset, "Attachment record runs past the end of the file");
  try {
    Cursor c(content.data(), len);
    c.u64();
    c.u64();
    c.string("name");
    c.string("media_type");
    const std::uint64_t n = c.u64();
    const auto d = c.bytes(n, "data");
    const std::uint64_t covered = c.pos();
    const std::uint32_t stored = c.u32();
    if (options_.verify_crcs && stored != 0 && crc32(content.data(), static_cast<std::size_t>(covered)) != stored)
      fail(a.offset, "attachment '" + a.name + "' CRC mismatch");
    return {d.begin(), d.end()};
  } catch (const Malformed& e) {
    fail(a.offset, std::string("bad Attachment record: ") + e.what());
  }
}

HalRecordingInfo hal_recording_info(const McapFileInfo& info, const std::string& file) {
  HalRecordingInfo h;
  for (const auto& m : info.metadata) {
    if (m.name != "regolith_hal" && m.name != "regolith_hal_end") continue;
    auto number = [&](const char* key, std::int64_t& out) {
      const auto it = m.values.find(key);
      if (it == m.values.end()) return;
      try {
        std::size_t used = 0;
        out = std::stoll(it->second, &used);
        if (used != it->second.size()) throw std::invalid_argument("trailing characters");
      } catch (const std::exception&) {
        throw InputError(file + ": metadata " + m.name + "." + key + ": not an integer: '" + it->second + "'");
      }
    };
    if (m.name == "regolith_hal") {
      h.found = true;
      number("time_origin_ns", h.origin_ns);
      number("ros_time_offset_ns", h.ros_offset_ns);
      const auto sim = m.values.find("simulated");
      h.simulated = sim != m.values.end() && sim->second == "true";
      const auto id = m.values.find("recording_id");
      if (id != m.values.end()) h.recording_id = id->second;
    } else {
      number("time_end_ns", h.end_ns);
    }
  }
  return h;
}

std::vector<std::filesystem::path> mcap_recording_files(const std::filesystem::path& first) {
  // The recording's identity: its HAL time origin and recording id (files written before the id
  // existed: the origin alone).
  const auto identity = [](const std::filesystem::path& f) {
    McapReader reader(f);
    const HalRecordingInfo h = hal_recording_info(reader.info(), f.string());
    return std::to_string(h.origin_ns) + "/" + h.recording_id;
  };
  const std::vector<std::filesystem::path> all = mcap_split_files(first);
  std::vector<std::filesystem::path> files{first};
  if (all.size() == 1) return files;
  const std::string id = identity(first);
  for (std::size_t k = 1; k < all.size() && identity(all[k]) == id; ++k) files.push_back(all[k]);
  return files;
}

}  // namespace regolith::record
