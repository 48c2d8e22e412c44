#pragma once
// FoxgloveServer: a Foxglove WebSocket protocol server (subprotocol foxglove.websocket.v1,
// https://github.com/foxglove/ws-protocol docs/spec.md), the subset Foxglove Studio / Lichtblick
// need to show live topics: serverInfo, advertise, subscribe / unsubscribe, binary messageData,
// status. Plain HTTP GETs (no WebSocket upgrade) get the built-in page's static files from
// options.web_root. Serves from one asio thread of its own; send_message() is called from any
// other thread (the DDS relay's) and never blocks. Per-client send queue limited in bytes: a
// client whose queue would exceed it is disconnected and counted, never waited for. Bounded
// number of clients. Not for real-time threads. (Its source is compiled as C++17: websocketpp 0.8 is not C++20.) Target
// regolith::live (websocketpp + Boost.Asio, nlohmann-json).
#include <cstddef>
#include <cstdint>
#include <memory>
#include <version>
#if defined(__cpp_lib_span)
#include <span>
#endif
#include <string>
#include <vector>

namespace regolith::live {

/// The Foxglove subprotocol this server speaks.
inline constexpr const char* kSubprotocol = "foxglove.websocket.v1";

/// One advertised channel.
struct Channel {
  std::uint32_t id = 0;
  std::string topic;            ///< e.g. /rover1/joint_states
  std::string encoding;         ///< message encoding, "cdr"
  std::string schema_name;      ///< e.g. sensor_msgs/msg/JointState
  std::string schema;           ///< e.g. the full ros2msg definition
  std::string schema_encoding;  ///< "ros2msg"
  /// Latched (state) topic: the server keeps its last message and sends it to each new
  /// subscription at once (as a transient-local DDS reader gets the latched sample).
  bool latched = false;
};

struct FoxgloveServerOptions {
  std::string address = "127.0.0.1";          ///< IP address to bind (loopback by default)
  std::uint16_t port = 8765;                  ///< 0 = any free port (see FoxgloveServer::port())
  std::string name = "regolith";              ///< serverInfo.name
  std::size_t max_clients = 8;                ///< connections beyond this are refused (HTTP 503), counted
  std::size_t max_queue_bytes = 8u << 20;     ///< per-client send queue limit (B); above: dropped
  std::size_t max_incoming_bytes = 1u << 20;  ///< largest client message accepted (B)
  int socket_send_buffer_bytes = 0;           ///< SO_SNDBUF of client sockets (0 = system default)
  /// Directory of the built-in page (index.html and its assets) answered to plain HTTP GETs on
  /// the same port; empty = no page (HTTP 404). See default_web_root() (web_root.hpp).
  std::string web_root;
  /// Access token (read_token_file()); empty = none, allowed only on a loopback address. When
  /// set, every request (WebSocket upgrade or page file) must carry it: `?token=` in the URL,
  /// `Authorization: Bearer <token>`, or the `regolith_token` cookie the server sets on the first
  /// request that carried it (so the page's own files and WebSocket follow). Others get HTTP 401.
  std::string token;
};

struct FoxgloveServerStats {
  std::uint64_t connected = 0;        ///< clients connected now
  std::uint64_t accepted = 0;         ///< connections accepted in total
  std::uint64_t refused = 0;          ///< connections refused (too many clients, wrong subprotocol)
  std::uint64_t dropped_slow = 0;     ///< clients disconnected because their send queue was full
  std::uint64_t bad_requests = 0;     ///< client messages answered with an error status
  std::uint64_t messages_sent = 0;    ///< messageData frames queued to clients
  std::uint64_t samples_dropped = 0;  ///< samples not relayed because the server thread lagged
  std::uint64_t unauthorized = 0;     ///< requests refused for a missing or wrong token (HTTP 401)
};

/// "[ADDR:]PORT" (e.g. "8765", "0.0.0.0:8765") into options.address / options.port. Throws
/// std::invalid_argument naming the text when the port is not 0..65535 or the address is empty.
void parse_listen_address(const std::string& text, FoxgloveServerOptions& options);

/// True for an address only this machine can reach: 127.0.0.0/8, ::1, "localhost".
bool is_loopback_address(const std::string& address);

/// Throws std::invalid_argument when `options` would listen beyond loopback without an access
/// token. The server's constructor checks it; a tool may check it before it builds anything else.
void check_access(const FoxgloveServerOptions& options);

/// The access token in `path`: the file's text without surrounding white space. Throws
/// std::invalid_argument naming the file when it cannot be read, is not a regular file, can be
/// read or written by its group or others (it must be mode 0600 or stricter), or holds no token
/// (empty, more than one line, or characters outside printable ASCII).
std::string read_token_file(const std::string& path);

class FoxgloveServer {
 public:
  /// Binds and listens (throws std::runtime_error naming the address when it cannot; throws
  /// std::invalid_argument when the address is not loopback and there is no token); no client
  /// is served before start(). Channel ids must be unique.
  FoxgloveServer(std::vector<Channel> channels, FoxgloveServerOptions options);
  ~FoxgloveServer();
  FoxgloveServer(const FoxgloveServer&) = delete;
  FoxgloveServer& operator=(const FoxgloveServer&) = delete;

  /// Starts the server thread (idempotent).
  void start();
  /// Disconnects every client and joins the thread (idempotent).
  void stop();

  /// The bound TCP port (the chosen one when options.port was 0).
  std::uint16_t port() const;
  const std::vector<Channel>& channels() const;

  /// Relays one message of `channel_id` to every client subscribed to it (thread-safe, never
  /// blocks; the bytes are copied). `receive_ns`: the messageData timestamp (ns).
  void send_message(std::uint32_t channel_id, std::uint64_t receive_ns, const std::uint8_t* data, std::size_t size);
#if defined(__cpp_lib_span)
  void send_message(std::uint32_t channel_id, std::uint64_t receive_ns, std::span<const std::uint8_t> payload) {
    send_message(channel_id, receive_ns, payload.data(), payload.size());
  }
#endif
  /// True when at least one client is subscribed to `channel_id` (cheap; thread-safe).
  bool has_subscribers(std::uint32_t channel_id) const;

  FoxgloveServerStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace regolith::live
