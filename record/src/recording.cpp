#include "regolith/record/recording.hpp"

#include <algorithm>
#include <vector>

#include "regolith/core/error.hpp"
#include "regolith/record/cdr.hpp"
#include "regolith/record/hal_messages.hpp"
#include "regolith/record/hal_recorder.hpp"
#include "regolith/record/mcap_reader.hpp"

namespace regolith::record {

RecordedDeployment recorded_deployment(McapReader& reader, const std::filesystem::path& file) {
  RecordedDeployment d;
  for (const auto& a : reader.info().attachments) {
    if (a.media_type != "application/yaml") continue;
    const std::vector<std::uint8_t> bytes = reader.read_attachment(a);
    d.text.assign(bytes.begin(), bytes.end());
    d.name = (std::filesystem::absolute(file).parent_path() / a.name).string();
    break;
  }
  return d;
}

RecordedDeployment recorded_deployment(const std::filesystem::path& file) {
  McapReader reader(file);
  return recorded_deployment(reader, file);
}

RecordedFrame recorded_camera_frame(const std::filesystem::path& file, const std::string& device, std::size_t index) {
  McapReader reader(file);
  const std::string prefix = "/hal/cameras/", suffix = "/image";
  std::vector<std::string> cameras;
  for (const auto& [id, ch] : reader.info().channels) {
    const std::string& t = ch.topic;
    if (t.size() > prefix.size() + suffix.size() && t.starts_with(prefix) && t.ends_with(suffix))
      cameras.push_back(t.substr(prefix.size(), t.size() - prefix.size() - suffix.size()));
  }
  std::string list;
  for (const auto& c : cameras) list += (list.empty() ? "" : ", ") + c;
  if (cameras.empty())
    throw InputError(file.string() +
                     ": no camera frames recorded (no /hal/cameras/<id>/image channel: record with "
                     "`regolith run --record`, which records the devices' inputs)");
  RecordedFrame out;
  out.device = device;
  if (device.empty()) {
    if (cameras.size() > 1)
      throw InputError(file.string() + ": " + std::to_string(cameras.size()) + " cameras recorded (" + list +
                       "): choose one with --device");
    out.device = cameras.front();
  } else if (std::find(cameras.begin(), cameras.end(), device) == cameras.end()) {
    throw InputError(file.string() + ": no camera '" + device + "' recorded (recorded: " + list + ")");
  }
  const std::string topic = hal_camera_topic(out.device);
  for (const auto& [id, ch] : reader.info().channels) {
    if (ch.topic != topic) continue;
    const auto n = reader.info().message_counts.find(id);
    if (n != reader.info().message_counts.end()) out.count += static_cast<std::size_t>(n->second);
  }
  bool found = false;
  std::size_t seen = 0;
  const auto problems = reader.for_each_message([&](const MessageView& m) {
    if (m.channel.topic != topic) return;
    if (seen++ != index) return;
    reader.stop();  // the chunks after this one are not decompressed
    try {
      DecodedImage d = decode_image(m.data);
      out.image = std::move(d.image);
      out.stamp = d.stamp;
      out.sequence = m.sequence;
      found = true;
    } catch (const std::exception& e) {
      throw InputError(file.string() + ": " + topic + " frame " + std::to_string(index) + ": " + e.what());
    }
  });
  out.index = index;
  if (!found) {
    std::string why = file.string() + ": " + topic + " has " + std::to_string(seen) + " frame(s); frame " +
                      std::to_string(index) + " is past the end";
    if (!problems.empty()) why += " (" + reader.describe(problems.front()) + ")";
    throw InputError(why);
  }
  out.deployment = recorded_deployment(reader, file);
  return out;
}

TimeNs last_hal_stamp(McapReader& reader) {
  TimeNs last = -1;
  // Damaged chunks are skipped (for_each_message reports them; the readable ones count).
  (void)reader.for_each_message([&](const MessageView& m) {
    if (m.channel.topic.rfind("/hal/", 0) != 0) return;
    try {
      CdrReader r(m.data);
      last = std::max<TimeNs>(last, r.header());
    } catch (const std::exception&) {  // a message that does not decode says nothing of the time
    }
  });
  return last;
}

}  // namespace regolith::record
