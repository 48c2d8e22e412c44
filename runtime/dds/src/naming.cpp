#include "regolith/dds/naming.hpp"

#include <stdexcept>

namespace regolith::dds {
namespace {

bool is_name_char(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_';
}

// Checks "a/b/c" (no leading or trailing slash). `what` names the thing for the
// message.
void check_tokens(std::string_view s, std::string_view what, std::string_view original) {
  std::size_t start = 0;
  while (start <= s.size()) {
    const std::size_t end = s.find('/', start);
    const std::string_view tok = s.substr(start, end == std::string_view::npos ? end : end - start);
    if (tok.empty())
      throw std::invalid_argument(std::string(what) + " '" + std::string(original) +
                                  "': empty token (\"//\" or a trailing \"/\")");
    if (tok.front() >= '0' && tok.front() <= '9')
      throw std::invalid_argument(std::string(what) + " '" + std::string(original) + "': token '" + std::string(tok) +
                                  "' starts with a digit");
    for (char c : tok)
      if (!is_name_char(c))
        throw std::invalid_argument(std::string(what) + " '" + std::string(original) + "': character '" +
                                    std::string(1, c) + "' not allowed (only [A-Za-z0-9_/])");
    if (end == std::string_view::npos) break;
    start = end + 1;
  }
}

}  // namespace

std::string normalize_namespace(std::string_view ns) {
  std::string_view s = ns;
  if (!s.empty() && s.front() == '/') s.remove_prefix(1);
  if (!s.empty() && s.back() == '/') s.remove_suffix(1);
  if (s.empty()) return {};
  check_tokens(s, "namespace", ns);
  return std::string(s);
}

std::string ros_topic_name(std::string_view ns, std::string_view topic) {
  if (topic.empty()) throw std::invalid_argument("topic name: empty");
  const bool absolute = topic.front() == '/';
  const std::string_view rel = absolute ? topic.substr(1) : topic;
  if (rel.empty()) throw std::invalid_argument("topic name '/': empty");
  check_tokens(rel, "topic name", topic);
  // (built with append: GCC 12 reports a false -Wrestrict for `"/" +
  // std::string` at -O3)
  std::string out;
  out.reserve(ns.size() + rel.size() + 2);
  out.push_back('/');
  if (!absolute) {
    const std::string n = normalize_namespace(ns);
    if (!n.empty()) {
      out.append(n);
      out.push_back('/');
    }
  }
  out.append(rel);
  return out;
}

std::string wire_topic_name(std::string_view ns, std::string_view topic) {
  std::string out = "rt";
  out.append(ros_topic_name(ns, topic));
  return out;
}

}  // namespace regolith::dds
