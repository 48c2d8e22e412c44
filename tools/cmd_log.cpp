// regolith log info FILE.mcap: what an MCAP recording holds (record/README.md): profile, library,
// channels with their message counts, time range, chunks and compression, attachments, metadata;
// "truncated at byte N" for a file cut off mid-write (the complete part is still read).
// A file that is not MCAP, or whose data is damaged (CRC mismatch, undecodable chunk), ends with
// an error naming the file and the byte offset (exit status 2, bad input).
//
// regolith log export FILE.mcap --topic T... --out DIR [--format jsonl|csv] (builds with DDS only):
// every message of the chosen channels decoded from its CDR bytes by Cyclone DDS's own
// deserializer into the regolith C struct and written as one JSON line (or CSV row) per message.
// Raw CAN frames (/hal/encoders/<id>/can, /can_fd) become a can-utils `candump -l` log instead
// (<topic>.log, interface name = the encoder set's id, time = the receive stamp in ROS time: unix
// time live, the simulated clock under --sim-time), which canplayer and the `candump` encoder
// backend replay. The HAL recording's camera frames (sensor_msgs/Image, mono8 / bgr8) become
// lossless PNG files beside the lines (<topic>/000000.png, ...; the line names its file and renders
// the pixels as their byte count) and its attitudes (geometry_msgs/Vector3Stamped: roll, pitch,
// yaw) lines of their own: both decoded by the replay backends' decoders.
#include <cstdio>
#include <functional>
#include <memory>
#include <string>
#include <vector>
#ifdef REGOLITH_HAVE_DDS_RECORD
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <span>

#include <dds/dds.h>
#include <dds/ddsi/ddsi_serdata.h>
#include <dds/ddsi/ddsi_sertype.h>
#include <opencv2/imgcodecs.hpp>

#include "regolith/core/json_text.hpp"
#include "regolith/dds/json.hpp"
#include "regolith/dds/sample.hpp"
#include "regolith/dds/topics.hpp"
#include "regolith/hal/can.hpp"
#include "regolith/record/hal_messages.hpp"
#endif

#include "cli.hpp"
#include "regolith/core/error.hpp"
#include "regolith/core/text_file.hpp"
#include "regolith/record/info.hpp"
#include "regolith/record/mcap_reader.hpp"

namespace regolith::cli {
namespace {

#ifdef REGOLITH_HAVE_DDS_RECORD
namespace fs = std::filesystem;
using nlohmann::json;

/// Turns the serialized sample of one regolith type (4-byte encapsulation header + CDR body) back
/// into its C struct with Cyclone's own deserializer (ddsi_serdata_from_ser_iov validates and
/// normalizes the bytes, ddsi_serdata_to_sample fills the struct) and renders it with to_json.
/// The type's sertype is Cyclone's default one for the topic descriptor; the public C API of 0.10
/// does not hand it out, so it is taken from a serdata: one zeroed sample is written to a reader
/// of a private topic on `participant` (same-process delivery) and taken back with dds_takecdr.
class CdrDecoder {
 public:
  CdrDecoder(dds_entity_t participant, const dds::TopicInfo& t, int index) : info_(t) {
    const std::string name = "regolith_log_export_" + std::to_string(index);
    topic_ = dds_create_topic(participant, t.descriptor, name.c_str(), nullptr, nullptr);
    if (topic_ < 0) throw std::runtime_error("log export: dds_create_topic: " + std::string(dds_strretcode(topic_)));
    writer_ = dds_create_writer(participant, topic_, nullptr, nullptr);
    reader_ = dds_create_reader(participant, topic_, nullptr, nullptr);
    if (writer_ < 0 || reader_ < 0) throw std::runtime_error("log export: cannot create a DDS reader/writer");
    void* zero = dds_alloc(t.descriptor->m_size);
    const dds_return_t wrc = dds_write(writer_, zero);
    dds_free(zero);
    if (wrc < 0) throw std::runtime_error("log export: dds_write: " + std::string(dds_strretcode(wrc)));
    ddsi_serdata* sd = nullptr;
    dds_sample_info_t si;
    const dds_return_t n = dds_takecdr(reader_, &sd, 1, &si, DDS_ANY_STATE);
    if (n != 1 || sd == nullptr)
      throw std::runtime_error("log export: no Cyclone sertype for " + std::string(t.ros_type));
    type_ = ddsi_sertype_ref(sd->type);
    ddsi_serdata_unref(sd);
  }
  ~CdrDecoder() {
    if (type_ != nullptr) ddsi_sertype_unref(type_);
    if (reader_ > 0) dds_delete(reader_);
    if (writer_ > 0) dds_delete(writer_);
    if (topic_ > 0) dds_delete(topic_);
  }
  CdrDecoder(const CdrDecoder&) = delete;
  CdrDecoder& operator=(const CdrDecoder&) = delete;

  /// The message as JSON; nullopt when Cyclone refuses the bytes (malformed CDR). `with_sample`,
  /// when given, also sees the decoded C struct.
  std::optional<json> decode(std::span<const std::uint8_t> bytes,
                             const std::function<void(const void*)>& with_sample = nullptr) const {
    ddsrt_iovec_t iov;
    iov.iov_base = const_cast<std::uint8_t*>(bytes.data());
    iov.iov_len = static_cast<ddsrt_iov_len_t>(bytes.size());
    ddsi_serdata* sd = ddsi_serdata_from_ser_iov(type_, SDK_DATA, 1, &iov, bytes.size());
    if (sd == nullptr) return std::nullopt;
    void* sample = dds_alloc(info_.descriptor->m_size);
    const bool ok = ddsi_serdata_to_sample(sd, sample, nullptr, nullptr);
    ddsi_serdata_unref(sd);
    std::optional<json> out;
    if (ok) {
      out = info_.to_json(sample);
      if (with_sample) with_sample(sample);
    }
    dds_sample_free(sample, info_.descriptor, DDS_FREE_ALL);
    return out;
  }

 private:
  const dds::TopicInfo& info_;
  dds_entity_t topic_ = 0, writer_ = 0, reader_ = 0;
  ddsi_sertype* type_ = nullptr;
};

/// Nested keys joined with '.', array elements as name[i]; scalars only.
void flatten(const json& j, const std::string& prefix, std::vector<std::pair<std::string, const json*>>& out) {
  if (j.is_object()) {
    for (auto it = j.begin(); it != j.end(); ++it)
      flatten(it.value(), prefix.empty() ? it.key() : prefix + "." + it.key(), out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) flatten(j[i], prefix + "[" + std::to_string(i) + "]", out);
  } else {
    out.emplace_back(prefix, &j);
  }
}

std::string csv_field(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  return q + "\"";
}

std::string csv_value(const json& v) {
  if (v.is_null()) return "";
  if (v.is_string()) return csv_field(v.get<std::string>());
  return regolith::json_text(v);
}

struct LogExportArgs {
  std::string file;
  std::vector<std::string> topics;
  std::string out;
  std::string format = "jsonl";
};

/// The channel named `want`: the recorded name, the name without its leading slash, or (when only
/// one channel ends with it) the name without the namespace.
const record::Channel* find_channel(const record::McapFileInfo& info, const std::string& want) {
  std::vector<const record::Channel*> suffix;
  for (const auto& [id, c] : info.channels) {
    if (c.topic == want || c.topic == "/" + want) return &c;
    const std::string tail = want.starts_with('/') ? want : "/" + want;
    if (c.topic.size() > tail.size() && c.topic.ends_with(tail)) suffix.push_back(&c);
  }
  return suffix.size() == 1 ? suffix.front() : nullptr;
}

struct ExportChannel {
  const record::Channel* channel = nullptr;
  std::unique_ptr<CdrDecoder> decoder;
  fs::path path;
  std::ofstream out;
  std::vector<std::string> columns;  // csv: from the first message
  std::uint64_t written = 0, undecodable = 0;
  fs::path images;  // sensor_msgs/CompressedImage: each image's bytes as a file here
  enum class Can { kNone, kClassic, kFd } can = Can::kNone;     // raw CAN frames: written as a candump -l log
  std::string can_interface;                                    // the interface name in that log: the encoder set's id
  enum class Hal { kNone, kImage, kVector3 } hal = Hal::kNone;  // HAL frames (PNG files) and attitudes
};

// A HAL message's stamp as recorded (process clock), rendered as every builtin_interfaces/Time is.
json stamp_json(TimeNs t) {
  msgs::builtin_interfaces::Time m{};
  dds::set_time(m, t);
  return dds::to_json(m);
}

/// A HAL camera frame: its pixels as a lossless PNG `dir`/NNNNNN.png (NNNNNN = `index`), the
/// message's other fields as JSON with the pixels as their byte count; `file` = the PNG's name
/// relative to the output directory. Throws on undecodable bytes (std::exception) and on a file
/// that cannot be written (InputError).
json export_hal_image(std::span<const std::uint8_t> cdr, const fs::path& dir, std::uint64_t index, std::string& file) {
  const record::DecodedImage d = record::decode_image(cdr);
  char name[32];
  std::snprintf(name, sizeof name, "%06llu.png", static_cast<unsigned long long>(index));
  if (!cv::imwrite((dir / name).string(), d.image))
    throw InputError("log export: cannot write " + (dir / name).string());
  file = (dir.filename() / name).string();
  const int channels = d.image.channels();
  return {{"header", {{"stamp", stamp_json(d.stamp)}, {"frame_id", d.frame_id}}},
          {"height", d.image.rows},
          {"width", d.image.cols},
          {"encoding", channels == 1 ? "mono8" : "bgr8"},
          {"is_bigendian", 0},
          {"step", d.image.cols * channels},
          {"data", {{"bytes", d.image.total() * d.image.elemSize()}}}};
}

/// A HAL attitude (or attitude query): geometry_msgs/Vector3Stamped, vector = (roll, pitch, yaw) rad.
json export_hal_vector3(std::span<const std::uint8_t> cdr) {
  const record::DecodedAttitude d = record::decode_attitude(cdr);
  return {{"header", {{"stamp", stamp_json(d.stamp)}, {"frame_id", d.frame_id}}},
          {"vector", {{"x", d.a.roll_rad}, {"y", d.a.pitch_rad}, {"z", d.a.yaw_rad}}}};
}

// The channels `topics` name (find_channel), by channel id; an unknown name is an InputError
// listing what was recorded.
std::map<std::uint16_t, ExportChannel> select_channels(const record::McapFileInfo& info,
                                                       const std::vector<std::string>& topics,
                                                       const std::string& file) {
  std::map<std::uint16_t, ExportChannel> chans;
  for (const auto& t : topics) {
    const record::Channel* c = find_channel(info, t);
    if (c == nullptr) {
      std::string list;
      for (const auto& [id, ch] : info.channels) {
        const auto s = info.schemas.find(ch.schema_id);
        list += "\n  " + ch.topic + "  " + (s != info.schemas.end() ? s->second.name : std::string("(no schema)"));
      }
      throw InputError("log export: " + file + ": no channel '" + t +
                       "' (or more than one ends with it); recorded topics:" + list);
    }
    chans[c->id].channel = c;
  }
  return chans;
}

// Decides how channel `e` is exported (a candump log of raw CAN frames, the HAL recording's frames
// and attitudes, or a regolith DDS type through a CdrDecoder on `pp`, the `index`-th) and opens
// its file (and image directory) in `out_dir`.
void open_export_channel(ExportChannel& e, const record::McapFileInfo& info, const LogExportArgs& a, dds_entity_t pp,
                         int& index) {
  const auto s = info.schemas.find(e.channel->schema_id);
  const std::string schema = s != info.schemas.end() ? s->second.name : "";
  std::string stem = e.channel->topic;
  if (stem.starts_with('/')) stem.erase(0, 1);
  for (char& ch : stem)
    if (ch == '/') ch = '_';
  if (e.channel->message_encoding == "cdr" &&
      (schema == "can_msgs/msg/Frame" || schema == "ros2_socketcan_msgs/msg/FdFrame")) {
    // Raw CAN frames: the log every CAN tool reads (and the `candump` encoder backend replays).
    e.can = schema == "can_msgs/msg/Frame" ? ExportChannel::Can::kClassic : ExportChannel::Can::kFd;
    const std::string& topic = e.channel->topic;  // /hal/encoders/<id>/can
    const auto end = topic.rfind('/');
    const auto begin = end == std::string::npos || end == 0 ? std::string::npos : topic.rfind('/', end - 1);
    e.can_interface = begin == std::string::npos ? "can" : topic.substr(begin + 1, end - begin - 1);
    e.path = fs::path(a.out) / (stem + ".log");
    e.out.open(e.path, std::ios::binary | std::ios::trunc);
    if (!e.out) throw InputError("log export: cannot write " + e.path.string());
    return;
  }
  if (e.channel->message_encoding == "cdr" &&
      (schema == "sensor_msgs/msg/Image" || schema == "geometry_msgs/msg/Vector3Stamped")) {
    // The HAL recording's frames and attitudes: not DDS topic types of regolith, decoded as the
    // replay backends decode them.
    e.hal = schema == "sensor_msgs/msg/Image" ? ExportChannel::Hal::kImage : ExportChannel::Hal::kVector3;
  } else {
    const dds::TopicInfo* ti = nullptr;
    for (const auto& k : dds::known_topics())
      if (k.ros_type == schema) ti = &k;
    if (ti == nullptr || e.channel->message_encoding != "cdr")
      throw InputError("log export: " + e.channel->topic + ": schema '" + schema + "' (" + e.channel->message_encoding +
                       ") is not a regolith CDR type");
    e.decoder = std::make_unique<CdrDecoder>(pp, *ti, index++);
  }
  e.path = fs::path(a.out) / (stem + "." + a.format);
  if (schema == "sensor_msgs/msg/CompressedImage" || e.hal == ExportChannel::Hal::kImage) {  // viewable files too
    e.images = fs::path(a.out) / stem;
    make_output_dir(e.images.string(), "the exported images' directory");
  }
  e.out.open(e.path, std::ios::binary | std::ios::trunc);
  if (!e.out) throw InputError("log export: cannot write " + e.path.string());
}

// One recorded message of channel `e` into its file: a candump line, a JSON line or a CSV row
// (the header from the first message's fields). Undecodable payloads are counted, not fatal.
void export_message(ExportChannel& e, const record::MessageView& m, bool csv, TimeNs ros_offset_ns,
                    std::vector<std::pair<std::string, const json*>>& flat) {
  if (e.can != ExportChannel::Can::kNone) {
    try {
      const hal::CanFrame f = record::decode_can_frame(m.data, e.can == ExportChannel::Can::kFd);
      e.out << hal::format_candump_line(f, e.can_interface, f.stamp + ros_offset_ns) << '\n';
      ++e.written;
    } catch (const std::exception&) {
      ++e.undecodable;
    }
    return;
  }
  std::string image_file;
  const auto save_image = [&](const void* sample) {
    const auto& im = *static_cast<const msgs::sensor_msgs::CompressedImage*>(sample);
    const std::string fmt = im.format != nullptr ? im.format : "";
    char name[48];
    std::snprintf(name, sizeof name, "%06llu.%s", static_cast<unsigned long long>(e.written),
                  fmt.find("png") != std::string::npos ? "png" : "jpg");
    write_file((e.images / name).string(),
               std::string_view(reinterpret_cast<const char*>(im.data._buffer), im.data._length), "an exported image");
    image_file = (e.images.filename() / name).string();
  };
  std::optional<json> msg;
  if (e.hal != ExportChannel::Hal::kNone) {
    try {
      msg = e.hal == ExportChannel::Hal::kImage ? export_hal_image(m.data, e.images, e.written, image_file)
                                                : export_hal_vector3(m.data);
    } catch (const InputError&) {
      throw;
    } catch (const std::exception&) {  // damaged or foreign bytes: counted, the rest exported
    }
  } else {
    msg = e.images.empty() ? e.decoder->decode(m.data) : e.decoder->decode(m.data, save_image);
  }
  if (!msg) {
    ++e.undecodable;
    return;
  }
  // the bytes are in the file (data: their count): beside the message (jsonl), a column (csv)
  if (!image_file.empty() && csv) (*msg)["file"] = image_file;
  if (!csv) {
    json line = {{"log_time_ns", m.log_time},
                 {"publish_time_ns", m.publish_time},
                 {"sequence", m.sequence},
                 {"message", std::move(*msg)}};
    if (!image_file.empty()) line["file"] = image_file;
    // A recorded string need not be UTF-8 (a frame_id from another process): replaced, as
    // `regolith echo` does, instead of json throwing and ending the export.
    e.out << regolith::json_text(line) << '\n';
  } else {
    flat.clear();
    flatten(*msg, "", flat);
    if (e.written == 0) {
      e.out << "log_time_ns,publish_time_ns,sequence";
      for (const auto& [k, v] : flat) {
        e.columns.push_back(k);
        e.out << ',' << csv_field(k);
      }
      e.out << '\n';
    }
    std::map<std::string, const json*> by_key(flat.begin(), flat.end());
    e.out << m.log_time << ',' << m.publish_time << ',' << m.sequence;
    for (const auto& k : e.columns) {
      const auto f = by_key.find(k);
      e.out << ',' << (f != by_key.end() ? csv_value(*f->second) : std::string());
    }
    e.out << '\n';
  }
  ++e.written;
}

void run_export(const LogExportArgs& a) {
  if (a.format != "jsonl" && a.format != "csv")
    throw InputError("log export: --format must be jsonl or csv, not '" + a.format + "'");
  record::McapReader reader(a.file);
  const auto& info = reader.info();
  const record::HalRecordingInfo hal = record::hal_recording_info(info, a.file);
  // Declared before the decoders: they (their sertype references) go first, then the participant.
  dds_entity_t pp = 0;
  struct ParticipantGuard {
    dds_entity_t& p;
    ~ParticipantGuard() {
      if (p > 0) dds_delete(p);
    }
  } guard{pp};
  std::map<std::uint16_t, ExportChannel> chans = select_channels(info, a.topics, a.file);
  pp = dds_create_participant(DDS_DOMAIN_DEFAULT, nullptr, nullptr);
  if (pp < 0) throw std::runtime_error("log export: dds_create_participant: " + std::string(dds_strretcode(pp)));
  make_output_dir(a.out, "log export's output directory (--out)");
  int index = 0;
  for (auto& [id, e] : chans) open_export_channel(e, info, a, pp, index);
  const bool csv = a.format == "csv";
  std::vector<std::pair<std::string, const json*>> flat;
  auto problems = reader.for_each_message([&](const record::MessageView& m) {
    auto it = chans.find(m.channel.id);
    if (it != chans.end()) export_message(it->second, m, csv, hal.ros_offset_ns, flat);
  });
  for (auto& [id, e] : chans) {
    close_output(e.out, e.path.string(), "the exported log");
    std::printf("%s: %llu messages -> %s", e.channel->topic.c_str(), static_cast<unsigned long long>(e.written),
                e.path.string().c_str());
    if (!e.images.empty()) std::printf(" (images in %s/)", e.images.string().c_str());
    if (e.undecodable > 0)
      std::printf(" (%llu undecodable CDR payloads skipped)", static_cast<unsigned long long>(e.undecodable));
    std::printf("\n");
  }
  if (info.truncated)
    std::printf("truncated at byte %llu of %llu (no footer: exported up to the last complete record)\n",
                static_cast<unsigned long long>(info.readable_end), static_cast<unsigned long long>(info.file_size));
  for (const auto& p : info.problems) problems.push_back(p);
  for (const auto& p : problems) std::printf("damaged: %s\n", reader.describe(p).c_str());
  std::fflush(stdout);
  if (!problems.empty()) throw InputError(reader.describe(problems.front()));
}
#endif

struct LogInfoArgs {
  std::string file;
  bool scan = false;
};

const bool registered = add_command([](CLI::App& app) {
  CLI::App* log = group(app, "log", "inspect MCAP recordings");
  auto a = std::make_shared<LogInfoArgs>();
  CLI::App* info = log->add_subcommand("info", "channels, message counts, time range and chunks of an MCAP file");
  info->add_option("file", a->file, "MCAP file")->required();
  info->add_flag("--scan", a->scan, "read every chunk (decompress, check CRCs, count) instead of trusting the summary");
  info->callback([a] {
    record::McapReaderOptions o;
    o.use_summary = !a->scan;
    record::McapReader reader(a->file, o);  // InputError "FILE: byte N: ..." when not MCAP
    std::fputs(record::format_info(reader.info()).c_str(), stdout);
    std::fflush(stdout);
    if (!reader.info().problems.empty()) throw InputError(reader.describe(reader.info().problems.front()));
  });
#ifdef REGOLITH_HAVE_DDS_RECORD
  auto e = std::make_shared<LogExportArgs>();
  CLI::App* ex = log->add_subcommand("export", "decode channels of an MCAP file into JSON lines or CSV");
  ex->add_option("file", e->file, "MCAP file")->required();
  ex->add_option("--topic", e->topics, "recorded topic (repeat for more)")->required()->allow_extra_args(false);
  ex->add_option("--out", e->out, "output directory (created)")->required();
  ex->add_option("--format", e->format, "jsonl (default) or csv");
  ex->callback([e] { run_export(*e); });
#endif
});

}  // namespace
}  // namespace regolith::cli
