#pragma once
// What a Foxglove WebSocket client's text message asks of the server (`subscribe` /
// `unsubscribe`, foxglove.websocket.v1), checked against the advertised channels and the client's
// own subscriptions. Pure (no sockets, no threads; nlohmann-json inside): FoxgloveServer applies
// the result, tests/fuzz `live_messages` feeds it any bytes. C++17, as the server's source is.
#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace regolith::live {

/// Most subscriptions one connection may hold (each costs a map entry and, on a latched channel,
/// an immediate copy of its last message): more are refused with a status error.
inline constexpr std::size_t kMaxSubscriptionsPerClient = 1024;

struct SubscriptionChange {
  std::uint32_t subscription = 0;
  std::uint32_t channel = 0;
};

struct ClientMessageResult {
  std::vector<SubscriptionChange> added;    ///< now in `subs`: count them, answer latched channels
  std::vector<SubscriptionChange> removed;  ///< no longer in `subs`
  std::vector<std::string> errors;          ///< status messages for the client, in order
};

/// Applies one client text message to `subs` (subscription id -> channel id). `advertised(id)`
/// says whether a channel exists. The entries of a message that are valid apply even when others
/// are not (each bad one gives an error). Never throws on any input.
ClientMessageResult apply_client_message(std::string_view text, std::map<std::uint32_t, std::uint32_t>& subs,
                                         const std::function<bool(std::uint32_t)>& advertised,
                                         std::size_t max_subscriptions = kMaxSubscriptionsPerClient);

}  // namespace regolith::live
