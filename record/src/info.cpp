// format_info: the `regolith log info` text.
#include "regolith/record/info.hpp"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <map>
#include <set>

namespace regolith::record {
namespace {

__attribute__((format(printf, 1, 2))) std::string fmt(const char* f, ...) {
  va_list a;
  va_start(a, f);
  va_list b;
  va_copy(b, a);
  const int n = std::vsnprintf(nullptr, 0, f, a);
  va_end(a);
  std::string s(static_cast<std::size_t>(std::max(n, 0)), '\0');
  if (n > 0) std::vsnprintf(s.data(), s.size() + 1, f, b);
  va_end(b);
  return s;
}

std::string bytes_text(std::uint64_t n) {
  const double d = static_cast<double>(n);
  if (n < 1024) return std::to_string(n) + " B";
  if (n < (1ULL << 20)) return fmt("%.1f KiB", d / 1024.0);
  if (n < (1ULL << 30)) return fmt("%.1f MiB", d / 1048576.0);
  return fmt("%.2f GiB", d / 1073741824.0);
}

std::string seconds_text(std::uint64_t ns) {
  return fmt("%llu.%09llu", static_cast<unsigned long long>(ns / 1000000000ULL),
             static_cast<unsigned long long>(ns % 1000000000ULL));
}

}  // namespace

std::string format_info(const McapFileInfo& info) {
  std::string out;
  out += fmt("file:        %s (%s)\n", info.name.c_str(), bytes_text(info.file_size).c_str());
  out += fmt("profile:     %s\n", info.profile.empty() ? "(none)" : info.profile.c_str());
  out += fmt("library:     %s\n", info.library.empty() ? "(none)" : info.library.c_str());
  out += fmt("index:       %s\n", info.from_summary ? "summary (fast path)" : "none used: data section scanned");
  out += fmt("messages:    %llu\n", static_cast<unsigned long long>(info.message_count));
  if (info.message_count > 0) {
    const std::uint64_t d = info.message_end_time - info.message_start_time;
    out += fmt("time range:  %s .. %s s (log time)\n", seconds_text(info.message_start_time).c_str(),
               seconds_text(info.message_end_time).c_str());
    out += fmt("duration:    %.3f s\n", static_cast<double>(d) * 1e-9);
  }
  std::map<std::string, std::uint64_t> by_compression;
  std::uint64_t compressed = 0, uncompressed = 0;
  for (const auto& c : info.chunks) {
    ++by_compression[c.compression.empty() ? "none" : c.compression];
    compressed += c.compressed_size;
    uncompressed += c.uncompressed_size;
  }
  std::string kinds;
  for (const auto& [k, n] : by_compression) kinds += (kinds.empty() ? "" : ", ") + k + " " + std::to_string(n);
  out += fmt("chunks:      %zu", info.chunks.size());
  if (!kinds.empty()) out += " (" + kinds + ")";
  if (!info.chunks.empty())
    out += fmt(", %s stored / %s uncompressed", bytes_text(compressed).c_str(), bytes_text(uncompressed).c_str());
  out += "\n";
  out += fmt("channels:    %zu\n", info.channels.size());
  std::size_t topic_w = 5, schema_w = 6, enc_w = 8;
  for (const auto& [id, c] : info.channels) {
    topic_w = std::max(topic_w, c.topic.size());
    const auto s = info.schemas.find(c.schema_id);
    schema_w = std::max(schema_w, s == info.schemas.end() ? std::size_t{1} : s->second.name.size());
    enc_w = std::max(enc_w, c.message_encoding.size());
  }
  if (!info.channels.empty()) {
    out += fmt("  %5s  %-*s  %-*s  %-*s  %s\n", "id", static_cast<int>(topic_w), "topic", static_cast<int>(schema_w),
               "schema", static_cast<int>(enc_w), "encoding", "messages");
    for (const auto& [id, c] : info.channels) {
      const auto s = info.schemas.find(c.schema_id);
      const auto n = info.message_counts.find(id);
      out += fmt("  %5u  %-*s  %-*s  %-*s  %llu\n", static_cast<unsigned>(id), static_cast<int>(topic_w),
                 c.topic.c_str(), static_cast<int>(schema_w), s == info.schemas.end() ? "-" : s->second.name.c_str(),
                 static_cast<int>(enc_w), c.message_encoding.c_str(),
                 static_cast<unsigned long long>(n == info.message_counts.end() ? 0 : n->second));
    }
  }
  for (const auto& a : info.attachments)
    out += fmt("attachment:  %s (%s, %s)\n", a.name.c_str(), a.media_type.c_str(), bytes_text(a.data_size).c_str());
  for (const auto& m : info.metadata) {
    std::string kv;
    for (const auto& [k, v] : m.values) kv += (kv.empty() ? "" : ", ") + k + "=" + v;
    out += fmt("metadata:    %s: %s\n", m.name.c_str(), kv.c_str());
  }
  if (info.truncated)
    out += fmt("truncated at byte %llu of %llu (no footer: read up to the last complete record)\n",
               static_cast<unsigned long long>(info.readable_end), static_cast<unsigned long long>(info.file_size));
  for (const auto& p : info.problems)
    out += fmt("damaged:     byte %llu: %s\n", static_cast<unsigned long long>(p.offset), p.what.c_str());
  return out;
}

}  // namespace regolith::record
