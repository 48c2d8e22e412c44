// regolith::msgs::ros2msg_definition: the ros2msg schema text (rosbag2's format) from the
// embedded .msg files (generated ros2msg_embedded.cpp).
#include "regolith/msgs/ros2msg.hpp"

#include <algorithm>
#include <deque>
#include <set>
#include <stdexcept>

namespace regolith::msgs {
namespace detail {
struct EmbeddedMsg {
  std::string_view name;
  std::string_view text;
};
extern const EmbeddedMsg kEmbeddedMsgs[];
extern const unsigned kEmbeddedMsgCount;
}  // namespace detail

namespace {

bool is_primitive(std::string_view t) {
  static constexpr std::string_view kPrimitives[] = {"bool",   "byte",  "char",   "float32", "float64",
                                                     "int8",   "uint8", "int16",  "uint16",  "int32",
                                                     "uint32", "int64", "uint64", "string",  "wstring"};
  return std::find(std::begin(kPrimitives), std::end(kPrimitives), t) != std::end(kPrimitives);
}

std::string_view trim(std::string_view s) {
  const auto b = s.find_first_not_of(" \t\r");
  if (b == std::string_view::npos) return {};
  const auto e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

/// The complex types the fields of `text` (a message of package `pkg`) use, as "pkg/Type", in
/// field order. Constants are skipped; bounded strings (string<=N) are primitives.
std::vector<std::string> field_types(std::string_view pkg, std::string_view text) {
  std::vector<std::string> out;
  while (!text.empty()) {
    const auto nl = text.find('\n');
    std::string_view line = text.substr(0, nl);
    text = nl == std::string_view::npos ? std::string_view{} : text.substr(nl + 1);
    line = trim(line.substr(0, line.find('#')));
    if (line.empty()) continue;
    std::string_view type = line.substr(0, line.find_first_of(" \t"));
    if (const auto br = type.find('['); br != std::string_view::npos) type = type.substr(0, br);
    if (const auto lt = type.find('<'); lt != std::string_view::npos) type = type.substr(0, lt);
    if (is_primitive(type)) continue;
    std::string full =
        type.find('/') == std::string_view::npos ? std::string(pkg) + "/" + std::string(type) : std::string(type);
    out.push_back(std::move(full));
  }
  return out;
}

}  // namespace

std::string ros2msg_short_name(std::string_view ros_type) {
  const auto s1 = ros_type.find('/');
  if (s1 == std::string_view::npos || s1 == 0) return {};
  const std::string_view pkg = ros_type.substr(0, s1);
  std::string_view rest = ros_type.substr(s1 + 1);
  if (rest.substr(0, 4) == "msg/") rest = rest.substr(4);
  if (rest.empty() || rest.find('/') != std::string_view::npos) return {};
  return std::string(pkg) + "/" + std::string(rest);
}

std::string_view ros2msg_text(std::string_view ros_type) {
  const std::string name = ros2msg_short_name(ros_type);
  for (unsigned i = 0; i < detail::kEmbeddedMsgCount; ++i) {
    if (detail::kEmbeddedMsgs[i].name == name) return detail::kEmbeddedMsgs[i].text;
  }
  return {};
}

std::string ros2msg_definition(std::string_view ros_type) {
  const std::string root = ros2msg_short_name(ros_type);
  const std::string_view root_text = ros2msg_text(root);
  if (root_text.empty()) {
    throw std::invalid_argument("no ROS 2 message definition for type '" + std::string(ros_type) + "'");
  }
  std::string out(root_text);
  std::set<std::string> seen{root};
  std::deque<std::pair<std::string, std::string_view>> todo{{root, root_text}};
  while (!todo.empty()) {
    auto [name, text] = todo.front();
    todo.pop_front();
    const std::string pkg = name.substr(0, name.find('/'));
    for (std::string& dep : field_types(pkg, text)) {
      if (!seen.insert(dep).second) continue;
      const std::string_view dep_text = ros2msg_text(dep);
      if (dep_text.empty()) {
        throw std::invalid_argument("no ROS 2 message definition for type '" + dep + "' (used by " + name + ")");
      }
      if (!out.empty() && out.back() != '\n') out += '\n';
      out.append(80, '=');
      out += "\nMSG: " + dep + "\n";
      out += dep_text;
      todo.emplace_back(std::move(dep), dep_text);
    }
  }
  return out;
}

std::vector<std::string_view> ros2msg_types() {
  std::vector<std::string_view> out;
  for (unsigned i = 0; i < detail::kEmbeddedMsgCount; ++i) out.push_back(detail::kEmbeddedMsgs[i].name);
  std::sort(out.begin(), out.end());
  return out;
}

}  // namespace regolith::msgs
