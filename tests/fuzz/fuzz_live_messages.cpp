// libFuzzer target: the live view's client messages (regolith::live::apply_client_message, what
// FoxgloveServer does with a WebSocket text message): any bytes, against channels 1..8 and a
// connection that already holds three subscriptions. Nothing may escape, and the result must be
// consistent: every subscription on an advertised channel, none beyond the bound, what was added
// is held and what was removed is not.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <map>
#include <string_view>

#include "regolith/live/client_message.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace regolith::live;
  std::map<std::uint32_t, std::uint32_t> subs{{1, 1}, {2, 5}, {7, 8}};
  const auto advertised = [](std::uint32_t channel) { return channel >= 1 && channel <= 8; };
  constexpr std::size_t kMax = 16;  // small, so that inputs reach the bound
  const ClientMessageResult r =
      apply_client_message(std::string_view(reinterpret_cast<const char*>(data), size), subs, advertised, kMax);
  if (subs.size() > kMax) std::abort();
  for (const auto& [sub, channel] : subs)
    if (!advertised(channel)) std::abort();
  for (const SubscriptionChange& a : r.added) {
    const auto it = subs.find(a.subscription);
    if (it == subs.end() || it->second != a.channel) std::abort();
  }
  for (const SubscriptionChange& g : r.removed)
    if (subs.count(g.subscription) != 0) std::abort();
  return 0;
}
