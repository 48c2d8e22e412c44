// The rules a Foxglove client's text messages are held to (regolith::live::apply_client_message):
// what FoxgloveServer applies, without a socket. The server's own tests check the same texts
// arrive as status messages over a real connection (test_foxglove_server.cpp).
#include <map>
#include <string>

#include <gtest/gtest.h>

#include "regolith/live/client_message.hpp"

namespace {
using namespace regolith::live;

const auto kChannels = [](std::uint32_t c) { return c == 1 || c == 2; };

TEST(ClientMessage, SubscribesAndUnsubscribesWhatIsValidAndNamesTheRest) {
  std::map<std::uint32_t, std::uint32_t> subs;
  ClientMessageResult r = apply_client_message(
      R"({"op":"subscribe","subscriptions":[{"id":10,"channelId":1},{"id":11,"channelId":999},{"id":10,"channelId":2},7]})",
      subs, kChannels);
  ASSERT_EQ(r.added.size(), 1u);
  EXPECT_EQ(r.added[0].subscription, 10u);
  EXPECT_EQ(r.added[0].channel, 1u);
  ASSERT_EQ(r.errors.size(), 3u);
  EXPECT_EQ(r.errors[0], "subscribe: unknown channel 999");
  EXPECT_EQ(r.errors[1], "subscribe: subscription id 10 already in use");
  EXPECT_EQ(r.errors[2], "subscribe: each subscription needs unsigned 'id' and 'channelId'");
  EXPECT_EQ(subs.size(), 1u);
  r = apply_client_message(R"({"op":"unsubscribe","subscriptionIds":[10,42,"x"]})", subs, kChannels);
  ASSERT_EQ(r.removed.size(), 1u);
  EXPECT_EQ(r.removed[0].channel, 1u);
  ASSERT_EQ(r.errors.size(), 2u);
  EXPECT_EQ(r.errors[0], "unsubscribe: unknown subscription 42");
  EXPECT_EQ(r.errors[1], "unsubscribe: unknown subscription \"x\"");
  EXPECT_TRUE(subs.empty());
  for (const char* bad : {"{not json", "[1]", R"({"op":1})", R"({"op":"advertise"})", R"({"op":"unsubscribe"})"}) {
    r = apply_client_message(bad, subs, kChannels);
    EXPECT_EQ(r.errors.size(), 1u) << bad;
    EXPECT_TRUE(r.added.empty() && r.removed.empty()) << bad;
  }
}

TEST(ClientMessage, AConnectionHoldsABoundedNumberOfSubscriptions) {
  std::map<std::uint32_t, std::uint32_t> subs;
  std::string many = R"({"op":"subscribe","subscriptions":[)";
  for (int i = 0; i < 1030; ++i)
    many += (i ? "," : "") + std::string(R"({"id":)") + std::to_string(i) + R"(,"channelId":2})";
  many += "]}";
  const ClientMessageResult r = apply_client_message(many, subs, kChannels);
  EXPECT_EQ(subs.size(), kMaxSubscriptionsPerClient);
  EXPECT_EQ(r.added.size(), kMaxSubscriptionsPerClient);
  ASSERT_EQ(r.errors.size(), 6u);
  EXPECT_EQ(r.errors[0], "subscribe: at most 1024 subscriptions per connection");
}

TEST(ClientMessage, ADeeplyNestedValueIsNamedByItsTypeNotWrittenOut) {
  // 1 MB (the server's message bound) nests 500 000 levels deep: writing such a value into the
  // error message recursed once per level and overflowed the stack of the server's thread.
  const std::size_t depth = 500000;
  const std::string text = R"({"op":"unsubscribe","subscriptionIds":[)" + std::string(depth, '[') +
                           std::string(depth, ']') + R"(,{"a":1},")" + std::string(100, 'y') + R"("]})";
  std::map<std::uint32_t, std::uint32_t> subs;
  const ClientMessageResult r = apply_client_message(text, subs, kChannels);
  ASSERT_EQ(r.errors.size(), 3u);
  EXPECT_EQ(r.errors[0], "unsubscribe: unknown subscription (an array)");
  EXPECT_EQ(r.errors[1], "unsubscribe: unknown subscription (an object)");
  EXPECT_EQ(r.errors[2], "unsubscribe: unknown subscription (a string of 100 bytes)");
}

}  // namespace
