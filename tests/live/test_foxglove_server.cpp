// FoxgloveServer against a hand-written RFC 6455 client (ws_test_client.hpp): serverInfo and
// advertise on connect, the binary messageData layout, error statuses for bad client messages
// (the server keeps serving), a stalled client dropped and counted while another keeps receiving,
// the client limit and the subprotocol check.
#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "regolith/live/foxglove_server.hpp"
#include "ws_test_client.hpp"

namespace {

namespace rl = regolith::live;
using nlohmann::json;
using regolith::live::testing::WsClient;

std::vector<rl::Channel> two_channels() {
  return {{1, "/t/a", "cdr", "std_msgs/msg/String", "string data\n", "ros2msg"},
          {7, "/t/b", "cdr", "std_msgs/msg/Int32", "int32 data\n", "ros2msg"}};
}

rl::FoxgloveServerOptions any_port() {
  rl::FoxgloveServerOptions o;
  o.port = 0;
  return o;
}

template <class Pred>
bool eventually(Pred pred, std::chrono::milliseconds timeout = std::chrono::seconds(10)) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < end) {
    if (pred()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  return pred();
}

json read_json(WsClient& c) {
  auto f = c.read();
  if (!f || f->opcode != 1) return json();
  return json::parse(f->payload, nullptr, false);
}

std::uint64_t le(const std::string& s, std::size_t off, int bytes) {
  std::uint64_t v = 0;
  for (int i = bytes - 1; i >= 0; --i) v = (v << 8) | static_cast<unsigned char>(s[off + static_cast<std::size_t>(i)]);
  return v;
}

void expect_error_status(WsClient& c, const std::string& containing) {
  const json s = read_json(c);
  ASSERT_TRUE(s.is_object()) << containing;
  EXPECT_EQ(s.value("op", ""), "status");
  EXPECT_EQ(s.value("level", -1), 2);
  EXPECT_NE(s.value("message", "").find(containing), std::string::npos) << s.dump();
}

}  // namespace

TEST(FoxgloveServer, ParsesListenAddress) {
  rl::FoxgloveServerOptions o;
  rl::parse_listen_address("9000", o);
  EXPECT_EQ(o.address, "127.0.0.1");
  EXPECT_EQ(o.port, 9000);
  rl::parse_listen_address("0.0.0.0:8765", o);
  EXPECT_EQ(o.address, "0.0.0.0");
  EXPECT_EQ(o.port, 8765);
  EXPECT_THROW(rl::parse_listen_address("70000", o), std::invalid_argument);
  EXPECT_THROW(rl::parse_listen_address("host:", o), std::invalid_argument);
  EXPECT_THROW(rl::parse_listen_address(":80", o), std::invalid_argument);
}

TEST(FoxgloveServer, AdvertisesRelaysAndAnswersBadMessagesWithErrors) {
  rl::FoxgloveServer server(two_channels(), any_port());
  server.start();
  ASSERT_GT(server.port(), 0);
  WsClient c(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(c.ok()) << c.response();
  EXPECT_NE(c.response().find("Sec-WebSocket-Protocol: foxglove.websocket.v1"), std::string::npos) << c.response();

  const json info = read_json(c);
  EXPECT_EQ(info.value("op", ""), "serverInfo");
  EXPECT_EQ(info.value("name", ""), "regolith");
  EXPECT_EQ(info["capabilities"], json::array());
  EXPECT_EQ(info["supportedEncodings"], json::array({"cdr"}));
  const json adv = read_json(c);
  EXPECT_EQ(adv.value("op", ""), "advertise");
  ASSERT_EQ(adv["channels"].size(), 2u);
  EXPECT_EQ(adv["channels"][1]["id"], 7);
  EXPECT_EQ(adv["channels"][1]["topic"], "/t/b");
  EXPECT_EQ(adv["channels"][1]["encoding"], "cdr");
  EXPECT_EQ(adv["channels"][1]["schemaName"], "std_msgs/msg/Int32");
  EXPECT_EQ(adv["channels"][1]["schema"], "int32 data\n");
  EXPECT_EQ(adv["channels"][1]["schemaEncoding"], "ros2msg");

  // Bad messages: each answered with an error status; the connection stays usable.
  ASSERT_TRUE(c.send_text("{not json"));
  expect_error_status(c, "invalid JSON");
  ASSERT_TRUE(c.send_text(R"({"op":"bogus"})"));
  expect_error_status(c, "unsupported op 'bogus'");
  ASSERT_TRUE(c.send_text(R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":999}]})"));
  expect_error_status(c, "unknown channel 999");
  ASSERT_TRUE(c.send_text(R"({"op":"subscribe","subscriptions":"x"})"));
  expect_error_status(c, "must be an array");
  ASSERT_TRUE(c.send_text(R"({"op":"unsubscribe","subscriptionIds":[42]})"));
  expect_error_status(c, "unknown subscription 42");
  // 1 MB nesting 400 000 levels deep: writing it into the error recursed once per level and
  // overflowed the server thread's stack (a remote crash); now it is named by its type.
  const std::string deep =
      R"({"op":"unsubscribe","subscriptionIds":[)" + std::string(400000, '[') + std::string(400000, ']') + "]}";
  ASSERT_TRUE(c.send_text(deep));
  expect_error_status(c, "unknown subscription (an array)");
  ASSERT_TRUE(c.send(2, std::string("\x01\x02\x03", 3)));
  expect_error_status(c, "binary client messages");
  EXPECT_EQ(server.stats().bad_requests, 7u);

  // A valid subscription after all that: messageData with the client's subscription id.
  ASSERT_TRUE(c.send_text(R"({"op":"subscribe","subscriptions":[{"id":33,"channelId":7}]})"));
  ASSERT_TRUE(eventually([&] { return server.has_subscribers(7); }));
  EXPECT_FALSE(server.has_subscribers(1));
  const std::vector<std::uint8_t> payload = {0x00, 0x01, 0x00, 0x00, 0x2a, 0x00, 0x00, 0x00};
  server.send_message(1, 5, payload);  // nobody subscribed: not sent
  server.send_message(7, 0x0102030405060708ULL, payload);
  auto f = c.read();
  ASSERT_TRUE(f.has_value());
  ASSERT_EQ(f->opcode, 2);
  ASSERT_EQ(f->payload.size(), 13u + payload.size());
  EXPECT_EQ(static_cast<unsigned char>(f->payload[0]), 0x01);
  EXPECT_EQ(le(f->payload, 1, 4), 33u);
  EXPECT_EQ(le(f->payload, 5, 8), 0x0102030405060708ULL);
  EXPECT_EQ(f->payload.substr(13), std::string(payload.begin(), payload.end()));

  ASSERT_TRUE(c.send_text(R"({"op":"unsubscribe","subscriptionIds":[33]})"));
  ASSERT_TRUE(eventually([&] { return !server.has_subscribers(7); }));
  EXPECT_EQ(server.stats().messages_sent, 1u);
  EXPECT_EQ(server.stats().bad_requests, 7u);
  server.stop();
}

TEST(FoxgloveServer, RefusesWrongSubprotocolAndClientsBeyondTheLimit) {
  auto o = any_port();
  o.max_clients = 1;
  rl::FoxgloveServer server(two_channels(), o);
  server.start();
  {
    WsClient wrong(server.port(), "something.else");
    EXPECT_FALSE(wrong.ok()) << wrong.response();
  }
  WsClient first(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(first.ok());
  WsClient second(server.port(), rl::kSubprotocol);
  EXPECT_FALSE(second.ok()) << second.response();
  EXPECT_NE(second.response().find("503"), std::string::npos) << second.response();
  EXPECT_EQ(server.stats().refused, 2u);
  EXPECT_EQ(server.stats().accepted, 1u);
}

TEST(FoxgloveServer, DropsAndCountsAStalledClientWhileOthersKeepReceiving) {
  auto o = any_port();
  o.max_queue_bytes = 64 * 1024;
  o.socket_send_buffer_bytes = 4096;
  rl::FoxgloveServer server(two_channels(), o);
  server.start();
  const std::string sub = R"({"op":"subscribe","subscriptions":[{"id":1,"channelId":1}]})";

  WsClient stalled(server.port(), rl::kSubprotocol, 4096);  // reads nothing after the handshake
  ASSERT_TRUE(stalled.ok());
  ASSERT_TRUE(stalled.send_text(sub));
  WsClient good(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(good.ok());
  ASSERT_TRUE(good.send_text(sub));
  ASSERT_TRUE(eventually([&] { return server.stats().connected == 2; }));

  std::atomic<bool> done{false};
  std::atomic<std::uint64_t> good_messages{0};
  std::thread reader([&] {
    while (!done.load()) {
      auto f = good.read(100);
      if (f && f->opcode == 2) good_messages.fetch_add(1);
    }
  });
  // Both clients subscribe to channel 1; has_subscribers() only tells that one did. Messages go
  // out until the good client has received one: its subscription is then in force, and it
  // receives every message sent after the stream settles.
  const std::vector<std::uint8_t> payload(16 * 1024, 0x5a);
  std::uint64_t sent = 0;
  ASSERT_TRUE(eventually([&] { return server.has_subscribers(1); }));
  ASSERT_TRUE(eventually(
      [&] {
        server.send_message(1, ++sent, payload);
        return eventually([&] { return good_messages.load() > 0; }, std::chrono::milliseconds(200));
      },
      std::chrono::seconds(30)));
  std::uint64_t settled = good_messages.load();
  do {  // until nothing more arrives for 300 ms
    settled = good_messages.load();
    std::this_thread::sleep_for(std::chrono::milliseconds(300));
  } while (good_messages.load() != settled);
  const std::uint64_t sent_base = sent;
  // The sender is paced by the good client's reading (at most two messages in flight to it), so
  // however slowly a loaded machine runs its reader, only the client that reads nothing falls
  // behind by more than the 64 KB queue.
  const auto send_paced = [&] {
    const bool caught_up = eventually([&] { return (sent - sent_base) - (good_messages.load() - settled) <= 2; },
                                      std::chrono::seconds(30));
    server.send_message(1, ++sent, payload);
    return caught_up;
  };
  bool paced = true;
  const bool dropped = eventually(
      [&] {
        paced = send_paced() && paced;
        return server.stats().dropped_slow == 1;
      },
      std::chrono::seconds(60));
  ASSERT_TRUE(dropped) << "sent " << sent;
  EXPECT_TRUE(paced) << "the good client stopped receiving";
  EXPECT_TRUE(eventually([&] { return server.stats().connected == 1; }));
  // The good client keeps receiving after the drop.
  const std::uint64_t before = good_messages.load();
  EXPECT_TRUE(eventually([&] {
    paced = send_paced() && paced;
    return good_messages.load() >= before + 20;
  }));
  EXPECT_TRUE(paced) << "the good client stopped receiving after the drop";
  done.store(true);
  reader.join();
  EXPECT_EQ(server.stats().dropped_slow, 1u);
  server.stop();
}

TEST(FoxgloveServer, SendsALatchedChannelsLastMessageToANewSubscription) {
  auto channels = two_channels();
  channels[0].latched = true;
  rl::FoxgloveServer server(channels, any_port());
  server.start();
  const std::vector<std::uint8_t> first = {0x00, 0x01, 0x00, 0x00, 0x01};
  const std::vector<std::uint8_t> second = {0x00, 0x01, 0x00, 0x00, 0x02};
  server.send_message(1, 10, first);  // no client yet: kept
  server.send_message(1, 20, second);
  WsClient c(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(c.ok());
  ASSERT_TRUE(read_json(c).is_object());  // serverInfo
  ASSERT_TRUE(read_json(c).is_object());  // advertise
  ASSERT_TRUE(c.send_text(R"({"op":"subscribe","subscriptions":[{"id":4,"channelId":1}]})"));
  auto f = c.read();
  ASSERT_TRUE(f.has_value());
  ASSERT_EQ(f->opcode, 2);
  EXPECT_EQ(le(f->payload, 1, 4), 4u);
  EXPECT_EQ(le(f->payload, 5, 8), 20u);
  EXPECT_EQ(f->payload.substr(13), std::string(second.begin(), second.end()));
}

TEST(FoxgloveServer, ClosesAClientSendingAnOversizedMessageAndKeepsServingOthers) {
  rl::FoxgloveServer server(two_channels(), any_port());  // max_incoming_bytes 1 MB
  server.start();
  WsClient big(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(big.ok());
  ASSERT_TRUE(read_json(big).is_object());
  ASSERT_TRUE(read_json(big).is_object());
  big.send_text(std::string(2u << 20, ' '));  // may fail part-way once the server closes
  auto f = big.read();
  ASSERT_TRUE(f.has_value());
  EXPECT_EQ(f->opcode, 8);  // close
  ASSERT_GE(f->payload.size(), 2u);
  EXPECT_EQ((static_cast<unsigned char>(f->payload[0]) << 8) | static_cast<unsigned char>(f->payload[1]), 1009);

  WsClient other(server.port(), rl::kSubprotocol);
  ASSERT_TRUE(other.ok());
  EXPECT_EQ(read_json(other).value("op", ""), "serverInfo");
}
