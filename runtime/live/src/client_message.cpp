#include "regolith/live/client_message.hpp"

#include <nlohmann/json.hpp>

namespace regolith::live {
namespace {

/// A client's value in an error message: a number or a short string as written, anything else by
/// its type. (Never dump() a client's array or object: a 1 MB message nests 500 000 levels deep,
/// and the serializer recurses once per level.)
std::string describe(const nlohmann::json& v) {
  if (v.is_number() || v.is_boolean() || v.is_null()) return v.dump();
  if (v.is_string()) {
    const std::string& s = v.get_ref<const std::string&>();
    return s.size() <= 40 ? nlohmann::json(s).dump() : "(a string of " + std::to_string(s.size()) + " bytes)";
  }
  return std::string("(an ") + (v.is_array() ? "array" : "object") + ")";
}

}  // namespace

ClientMessageResult apply_client_message(std::string_view text, std::map<std::uint32_t, std::uint32_t>& subs,
                                         const std::function<bool(std::uint32_t)>& advertised,
                                         std::size_t max_subscriptions) {
  using json = nlohmann::json;
  ClientMessageResult r;
  const json j = json::parse(text.begin(), text.end(), nullptr, false);
  if (j.is_discarded() || !j.is_object()) {
    r.errors.emplace_back("invalid JSON message");
    return r;
  }
  const auto op = j.find("op");
  if (op == j.end() || !op->is_string()) {
    r.errors.emplace_back("message without a string 'op'");
    return r;
  }
  const std::string o = op->get<std::string>();
  if (o == "subscribe") {
    const auto list = j.find("subscriptions");
    if (list == j.end() || !list->is_array()) {
      r.errors.emplace_back("subscribe: 'subscriptions' must be an array");
      return r;
    }
    for (const json& s : *list) {
      if (!s.is_object()) {
        r.errors.emplace_back("subscribe: each subscription needs unsigned 'id' and 'channelId'");
        continue;
      }
      const auto id = s.find("id");
      const auto ch = s.find("channelId");
      if (id == s.end() || ch == s.end() || !id->is_number_unsigned() || !ch->is_number_unsigned()) {
        r.errors.emplace_back("subscribe: each subscription needs unsigned 'id' and 'channelId'");
        continue;
      }
      const auto sub_id = id->get<std::uint64_t>();
      const auto channel_id = ch->get<std::uint64_t>();
      if (channel_id > 0xffffffffu || !advertised(static_cast<std::uint32_t>(channel_id))) {
        r.errors.push_back("subscribe: unknown channel " + std::to_string(channel_id));
        continue;
      }
      if (sub_id > 0xffffffffu || subs.count(static_cast<std::uint32_t>(sub_id)) != 0) {
        r.errors.push_back("subscribe: subscription id " + std::to_string(sub_id) + " already in use");
        continue;
      }
      if (subs.size() >= max_subscriptions) {
        r.errors.push_back("subscribe: at most " + std::to_string(max_subscriptions) + " subscriptions per connection");
        continue;
      }
      const SubscriptionChange c{static_cast<std::uint32_t>(sub_id), static_cast<std::uint32_t>(channel_id)};
      subs.emplace(c.subscription, c.channel);
      r.added.push_back(c);
    }
  } else if (o == "unsubscribe") {
    const auto ids = j.find("subscriptionIds");
    if (ids == j.end() || !ids->is_array()) {
      r.errors.emplace_back("unsubscribe: 'subscriptionIds' must be an array");
      return r;
    }
    for (const json& i : *ids) {
      const auto it = i.is_number_unsigned() && i.get<std::uint64_t>() <= 0xffffffffu
                          ? subs.find(static_cast<std::uint32_t>(i.get<std::uint64_t>()))
                          : subs.end();
      if (it == subs.end()) {
        r.errors.push_back("unsubscribe: unknown subscription " + describe(i));
        continue;
      }
      r.removed.push_back({it->first, it->second});
      subs.erase(it);
    }
  } else {
    r.errors.push_back("unsupported op '" + o + "'");
  }
  return r;
}

}  // namespace regolith::live
