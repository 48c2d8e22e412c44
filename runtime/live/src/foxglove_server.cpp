#include "regolith/live/foxglove_server.hpp"

#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <sys/socket.h>
#include <sys/stat.h>

#include <nlohmann/json.hpp>
#include <websocketpp/config/asio_no_tls.hpp>
#include <websocketpp/server.hpp>

#include "regolith/live/client_message.hpp"

namespace regolith::live {
namespace {

using WsServer = websocketpp::server<websocketpp::config::asio>;
using Hdl = websocketpp::connection_hdl;
using nlohmann::json;

constexpr std::uint8_t kOpMessageData = 0x01;
constexpr int kStatusError = 2;

void put_le(std::string& out, std::uint64_t v, int bytes) {
  for (int i = 0; i < bytes; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xffu));
}

/// The Content-Type of a page file by its extension; nullptr = a kind of file never served.
const char* content_type(const std::string& name) {
  static const std::pair<const char*, const char*> kTypes[] = {{".html", "text/html; charset=utf-8"},
                                                               {".js", "text/javascript; charset=utf-8"},
                                                               {".css", "text/css; charset=utf-8"},
                                                               {".svg", "image/svg+xml"},
                                                               {".png", "image/png"},
                                                               {".ico", "image/x-icon"}};
  for (const auto& [ext, type] : kTypes) {
    const std::size_t n = std::char_traits<char>::length(ext);
    if (name.size() > n && name.compare(name.size() - n, n, ext) == 0) return type;
  }
  return nullptr;
}

/// A plain file name of the web root: no directories, no `..`, no hidden files, nothing
/// percent-encoded, so a request can never name a file outside it.
bool plain_file_name(const std::string& name) {
  if (name.empty() || name.front() == '.' || name.find("..") != std::string::npos) return false;
  for (char ch : name) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') || (ch >= '0' && ch <= '9') || ch == '_' ||
                    ch == '-' || ch == '.';
    if (!ok) return false;
  }
  return true;
}

/// Equal without an early exit (the time taken does not tell how much of a guess was right).
bool same_secret(const std::string& a, const std::string& b) {
  unsigned diff = a.size() == b.size() ? 0u : 1u;
  for (std::size_t i = 0; i < a.size(); ++i)
    diff |=
        static_cast<unsigned>(static_cast<unsigned char>(a[i]) ^ static_cast<unsigned char>(i < b.size() ? b[i] : 0));
  return diff == 0;
}

/// %XX escapes decoded (a token in a URL arrives encodeURIComponent-ed); a broken escape stays.
std::string percent_decoded(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto hex = [](char c) {
      return c >= '0' && c <= '9'   ? c - '0'
             : c >= 'a' && c <= 'f' ? c - 'a' + 10
             : c >= 'A' && c <= 'F' ? c - 'A' + 10
                                    : -1;
    };
    if (s[i] == '%' && i + 2 < s.size() && hex(s[i + 1]) >= 0 && hex(s[i + 2]) >= 0) {
      out.push_back(static_cast<char>(hex(s[i + 1]) * 16 + hex(s[i + 2])));
      i += 2;
    } else {
      out.push_back(s[i]);
    }
  }
  return out;
}

/// The value of `key` in a query string ("a=1&token=x") or cookie header ("a=1; token=x"); the
/// separator is '&' or ';'. Empty when absent.
std::string find_value(const std::string& text, const std::string& key, char sep) {
  std::size_t pos = 0;
  while (pos <= text.size()) {
    std::size_t end = text.find(sep, pos);
    if (end == std::string::npos) end = text.size();
    std::string item = text.substr(pos, end - pos);
    const std::size_t first = item.find_first_not_of(' ');
    item = first == std::string::npos ? std::string() : item.substr(first);
    if (item.size() > key.size() && item.compare(0, key.size(), key) == 0 && item[key.size()] == '=')
      return item.substr(key.size() + 1);
    pos = end + 1;
  }
  return {};
}

}  // namespace

bool is_loopback_address(const std::string& a) {
  return a == "localhost" || a == "::1" || a.rfind("127.", 0) == 0;
}

std::string read_token_file(const std::string& path) {
  const auto bad = [&](const std::string& why) { return std::invalid_argument("token file '" + path + "': " + why); };
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw bad("cannot read it (" + std::string(std::strerror(errno)) + ")");
  if (!S_ISREG(st.st_mode)) throw bad("not a regular file");
  if ((st.st_mode & 077) != 0) {
    char mode[8];
    std::snprintf(mode, sizeof mode, "%04o", static_cast<unsigned>(st.st_mode & 07777));
    throw bad(std::string("mode ") + mode + " lets its group or others read or write it; `chmod 600 " + path + "`");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw bad("cannot read it");
  std::ostringstream text;
  text << in.rdbuf();
  std::string t = text.str();
  const std::size_t b = t.find_first_not_of(" \t\r\n"), e = t.find_last_not_of(" \t\r\n");
  t = b == std::string::npos ? std::string() : t.substr(b, e - b + 1);
  if (t.empty()) throw bad("empty: put the token in it (e.g. `openssl rand -hex 24 > " + path + "`)");
  if (t.size() > 4096) throw bad("longer than 4096 characters");
  for (char ch : t)
    if (ch < 0x21 || ch > 0x7e) throw bad("the token must be one word of printable ASCII (no spaces or line breaks)");
  return t;
}

void check_access(const FoxgloveServerOptions& options) {
  if (options.token.empty() && !is_loopback_address(options.address))
    throw std::invalid_argument("listening on " + options.address +
                                " (not a loopback address) needs an access token: "
                                "give a token file (`--token-file FILE` / live.token_file, mode 0600)");
}

void parse_listen_address(const std::string& text, FoxgloveServerOptions& options) {
  const auto colon = text.rfind(':');
  const std::string port = colon == std::string::npos ? text : text.substr(colon + 1);
  const std::string addr = colon == std::string::npos ? options.address : text.substr(0, colon);
  bool ok = !port.empty() && port.size() <= 5 && !addr.empty();
  unsigned long v = 0;
  for (char ch : port) {
    if (ch < '0' || ch > '9') ok = false;
  }
  if (ok) v = std::stoul(port);
  if (!ok || v > 65535) throw std::invalid_argument("expected [ADDR:]PORT with PORT 0..65535, got '" + text + "'");
  options.address = addr;
  options.port = static_cast<std::uint16_t>(v);
}

struct FoxgloveServer::Impl {
  struct Client {
    std::map<std::uint32_t, std::uint32_t> subs;  // subscription id -> channel id
    bool dropped = false;
  };

  std::vector<Channel> channels;
  std::map<std::uint32_t, std::size_t> channel_index;  // id -> index in channels
  FoxgloveServerOptions opts;
  WsServer ws;
  std::uint16_t bound_port = 0;
  std::thread thread;
  std::atomic<bool> started{false};
  std::atomic<bool> stopped{false};

  // Server-thread state.
  std::map<Hdl, Client, std::owner_less<Hdl>> clients;
  // Subscriber counts per channel (written on the server thread, read by any).
  std::unique_ptr<std::atomic<std::uint32_t>[]> subscribers;

  std::atomic<std::size_t> pending_bytes{0};  // posted to the server thread, not yet handled
  std::atomic<std::uint64_t> connected{0}, accepted{0}, refused{0}, dropped_slow{0}, bad_requests{0}, messages_sent{0},
      samples_dropped{0}, unauthorized{0};

  std::string info_text, advertise_text;
  // Last message of each latched channel (server thread only), by channel index.
  std::vector<std::shared_ptr<std::vector<std::uint8_t>>> last;
  std::vector<std::uint64_t> last_ns;

  /// Queues one messageData frame to `h`; false when the client's queue is full (then dropped).
  bool send_frame(const Hdl& h, Client& c, std::uint32_t sub, std::uint64_t receive_ns,
                  const std::vector<std::uint8_t>& data, std::string& frame) {
    websocketpp::lib::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    if (ec) return true;
    const std::size_t size = 1 + 4 + 8 + data.size();
    if (con->get_buffered_amount() + size > opts.max_queue_bytes) {
      drop(h, c);
      return false;
    }
    frame.clear();
    frame.reserve(size);
    frame.push_back(static_cast<char>(kOpMessageData));
    put_le(frame, sub, 4);
    put_le(frame, receive_ns, 8);
    frame.append(reinterpret_cast<const char*>(data.data()), data.size());
    if (!con->send(frame, websocketpp::frame::opcode::binary)) messages_sent.fetch_add(1);
    return true;
  }

  void send_text(const Hdl& h, const std::string& text) {
    websocketpp::lib::error_code ec;
    ws.send(h, text, websocketpp::frame::opcode::text, ec);
  }

  void status_error(const Hdl& h, const std::string& message) {
    bad_requests.fetch_add(1);
    send_text(h, json{{"op", "status"}, {"level", kStatusError}, {"message", message}}.dump());
  }

  /// Whether a request carries the token (always, without one): `?token=`, a bearer header or
  /// the cookie. `from_query` tells the caller to set the cookie.
  template <class Con>
  bool authorized(const Con& con, bool* from_query = nullptr) const {
    if (opts.token.empty()) return true;
    const std::string resource = con->get_resource();
    const std::size_t q = resource.find('?');
    const std::string query =
        q == std::string::npos ? std::string() : resource.substr(q + 1, resource.find('#', q) - q - 1);
    const std::string in_query = percent_decoded(find_value(query, "token", '&'));
    if (!in_query.empty() && same_secret(in_query, opts.token)) {
      if (from_query) *from_query = true;
      return true;
    }
    const std::string auth = con->get_request_header("Authorization");
    if (auth.rfind("Bearer ", 0) == 0 && same_secret(auth.substr(7), opts.token)) return true;
    const std::string cookie = find_value(con->get_request_header("Cookie"), "regolith_token", ';');
    return !cookie.empty() && same_secret(cookie, opts.token);
  }

  /// A plain HTTP request (no WebSocket upgrade): the built-in page's files from opts.web_root.
  void on_http(const Hdl& h) {
    websocketpp::lib::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    if (ec) return;
    bool from_query = false;
    if (!authorized(con, &from_query)) {
      unauthorized.fetch_add(1);
      con->set_status(websocketpp::http::status_code::unauthorized);
      con->replace_header("Content-Type", "text/plain; charset=utf-8");
      con->replace_header("WWW-Authenticate", "Bearer realm=\"regolith live\"");
      con->set_body("regolith live: this server needs its access token: open /?token=<the token file's contents>\n");
      return;
    }
    // The page's own files and its WebSocket then carry the token as a cookie (same origin only).
    if (from_query)
      con->replace_header("Set-Cookie", "regolith_token=" + opts.token + "; Path=/; HttpOnly; SameSite=Strict");
    auto reply = [&](websocketpp::http::status_code::value status, const std::string& type, std::string body) {
      con->set_status(status);
      con->replace_header("Content-Type", type);
      con->replace_header("Cache-Control", "no-cache");
      con->replace_header("X-Content-Type-Options", "nosniff");
      con->set_body(std::move(body));
    };
    const std::string text = "text/plain; charset=utf-8";
    if (con->get_request().get_method() != "GET") {
      con->replace_header("Allow", "GET");
      return reply(websocketpp::http::status_code::method_not_allowed, text, "only GET\n");
    }
    if (opts.web_root.empty()) {
      return reply(websocketpp::http::status_code::not_found, text,
                   "regolith live: the built-in page is not installed (no web root); connect Foxglove Studio or "
                   "Lichtblick to this address over WebSocket\n");
    }
    std::string path = con->get_resource();
    path = path.substr(0, path.find_first_of("?#"));
    if (path == "/") path = "/index.html";
    // Only origin-form paths ("/name"): anything else names no file.
    const std::string name = !path.empty() && path.front() == '/' ? path.substr(1) : std::string();
    const char* type = content_type(name);
    std::ifstream in;
    if (plain_file_name(name) && type != nullptr) {
      const std::filesystem::path file = std::filesystem::path(opts.web_root) / name;
      std::error_code fec;
      if (std::filesystem::is_regular_file(file, fec)) in.open(file, std::ios::binary);
    }
    if (!in.is_open()) return reply(websocketpp::http::status_code::not_found, text, "not found\n");
    std::ostringstream body;
    body << in.rdbuf();
    reply(websocketpp::http::status_code::ok, type, body.str());
  }

  void unsubscribe_all(Client& c) {
    for (const auto& [sub, ch] : c.subs) subscribers[channel_index.at(ch)].fetch_sub(1);
    c.subs.clear();
  }

  void on_text(const Hdl& h, Client& c, const std::string& text) {
    const ClientMessageResult r =
        apply_client_message(text, c.subs, [this](std::uint32_t channel) { return channel_index.count(channel) != 0; });
    for (const std::string& e : r.errors) status_error(h, e);
    for (const SubscriptionChange& gone : r.removed) subscribers[channel_index.at(gone.channel)].fetch_sub(1);
    // Every new subscription is counted before any is answered: a send that drops the client
    // uncounts all of c.subs (unsubscribe_all).
    for (const SubscriptionChange& sub : r.added) subscribers[channel_index.at(sub.channel)].fetch_add(1);
    for (const SubscriptionChange& sub : r.added) {
      const std::size_t index = channel_index.at(sub.channel);
      if (last[index]) {  // a latched channel's last message, at once
        std::string frame;
        if (!send_frame(h, c, sub.subscription, last_ns[index], *last[index], frame)) return;
      }
    }
  }

  void drop(const Hdl& h, Client& c) {
    c.dropped = true;
    unsubscribe_all(c);
    dropped_slow.fetch_add(1);
    websocketpp::lib::error_code ec;
    auto con = ws.get_con_from_hdl(h, ec);
    if (!ec) {
      // Never waits for the stalled client: the socket is closed, not the WebSocket handshake.
      boost::system::error_code bec;
      con->get_raw_socket().close(bec);
    }
  }

  void relay(std::uint32_t channel_id, std::uint64_t receive_ns,
             const std::shared_ptr<std::vector<std::uint8_t>>& data) {
    pending_bytes.fetch_sub(data->size());
    const std::size_t index = channel_index.at(channel_id);
    if (channels[index].latched) {
      last[index] = data;
      last_ns[index] = receive_ns;
    }
    std::string frame;
    for (auto& [h, c] : clients) {
      if (c.dropped) continue;
      for (const auto& [sub, ch] : c.subs) {
        // send_frame() may drop the client (clearing c.subs): stop iterating them then.
        if (ch == channel_id && !send_frame(h, c, sub, receive_ns, *data, frame)) break;
      }
    }
  }
};

FoxgloveServer::FoxgloveServer(std::vector<Channel> channels, FoxgloveServerOptions options)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  s.channels = std::move(channels);
  s.opts = std::move(options);
  check_access(s.opts);
  s.subscribers = std::make_unique<std::atomic<std::uint32_t>[]>(s.channels.size());
  s.last.resize(s.channels.size());
  s.last_ns.resize(s.channels.size(), 0);
  json adv = json::array();
  for (std::size_t i = 0; i < s.channels.size(); ++i) {
    const Channel& c = s.channels[i];
    if (!s.channel_index.emplace(c.id, i).second) {
      throw std::invalid_argument("FoxgloveServer: duplicate channel id " + std::to_string(c.id));
    }
    s.subscribers[i].store(0);
    adv.push_back({{"id", c.id},
                   {"topic", c.topic},
                   {"encoding", c.encoding},
                   {"schemaName", c.schema_name},
                   {"schema", c.schema},
                   {"schemaEncoding", c.schema_encoding}});
  }
  s.info_text = json{{"op", "serverInfo"},
                     {"name", s.opts.name},
                     {"capabilities", json::array()},
                     {"supportedEncodings", json::array({"cdr"})},
                     {"metadata", json::object()}}
                    .dump();
  s.advertise_text = json{{"op", "advertise"}, {"channels", adv}}.dump();

  s.ws.clear_access_channels(websocketpp::log::alevel::all);
  s.ws.clear_error_channels(websocketpp::log::elevel::all);
  s.ws.init_asio();
  s.ws.set_reuse_addr(true);
  s.ws.set_max_message_size(s.opts.max_incoming_bytes);
  s.ws.set_close_handshake_timeout(1000);
  s.ws.set_socket_init_handler([this](Hdl, boost::asio::ip::tcp::socket& sock) {
    if (impl_->opts.socket_send_buffer_bytes > 0) {
      const int v = impl_->opts.socket_send_buffer_bytes;
      setsockopt(sock.native_handle(), SOL_SOCKET, SO_SNDBUF, &v, sizeof v);
    }
  });
  s.ws.set_validate_handler([this](Hdl h) {
    Impl& m = *impl_;
    auto con = m.ws.get_con_from_hdl(h);
    if (!m.authorized(con)) {
      m.unauthorized.fetch_add(1);
      con->set_status(websocketpp::http::status_code::unauthorized);
      return false;
    }
    if (m.clients.size() >= m.opts.max_clients) {
      m.refused.fetch_add(1);
      con->set_status(websocketpp::http::status_code::service_unavailable);
      return false;
    }
    for (const std::string& p : con->get_requested_subprotocols()) {
      if (p == kSubprotocol) {
        con->select_subprotocol(p);
        m.clients.emplace(h, Impl::Client{});  // counted against max_clients from the handshake on
        return true;
      }
    }
    m.refused.fetch_add(1);
    con->set_status(websocketpp::http::status_code::bad_request);
    return false;
  });
  s.ws.set_http_handler([this](Hdl h) { impl_->on_http(h); });
  s.ws.set_open_handler([this](Hdl h) {
    impl_->connected.fetch_add(1);
    impl_->accepted.fetch_add(1);
    impl_->send_text(h, impl_->info_text);
    impl_->send_text(h, impl_->advertise_text);
  });
  auto gone = [this](Hdl h) {
    Impl& m = *impl_;
    auto it = m.clients.find(h);
    if (it == m.clients.end()) return;
    m.unsubscribe_all(it->second);
    m.clients.erase(it);
  };
  s.ws.set_close_handler([this, gone](Hdl h) {
    impl_->connected.fetch_sub(1);
    gone(h);
  });
  s.ws.set_fail_handler([gone](Hdl h) { gone(h); });
  s.ws.set_message_handler([this](Hdl h, WsServer::message_ptr msg) {
    Impl& m = *impl_;
    auto it = m.clients.find(h);
    if (it == m.clients.end() || it->second.dropped) return;
    if (msg->get_opcode() != websocketpp::frame::opcode::text) {
      return m.status_error(h, "binary client messages are not supported (no clientPublish capability)");
    }
    try {
      m.on_text(h, it->second, msg->get_payload());
    } catch (const std::exception& e) {
      m.status_error(h, std::string("bad message: ") + e.what());
    }
  });

  boost::system::error_code aec;
  const auto addr = boost::asio::ip::make_address(s.opts.address, aec);
  if (aec) throw std::runtime_error("live: bad address '" + s.opts.address + "': " + aec.message());
  websocketpp::lib::error_code ec;
  s.ws.listen(boost::asio::ip::tcp::endpoint(addr, s.opts.port), ec);
  if (ec) {
    throw std::runtime_error("live: cannot listen on " + s.opts.address + ":" + std::to_string(s.opts.port) + ": " +
                             ec.message());
  }
  s.bound_port = s.ws.get_local_endpoint(aec).port();
  s.ws.start_accept(ec);
  if (ec) throw std::runtime_error("live: cannot accept on port " + std::to_string(s.bound_port) + ": " + ec.message());
}

FoxgloveServer::~FoxgloveServer() {
  stop();
}

void FoxgloveServer::start() {
  Impl& s = *impl_;
  if (s.started.load() || s.stopped.load()) return;
  s.started.store(true);
  s.thread = std::thread([this] {
    for (;;) {
      try {
        impl_->ws.run();
        return;
      } catch (...) {  // a handler must never end the server thread
      }
    }
  });
}

void FoxgloveServer::stop() {
  Impl& s = *impl_;
  if (s.stopped.exchange(true)) return;
  s.ws.get_io_service().post([this] {
    Impl& m = *impl_;
    websocketpp::lib::error_code ec;
    m.ws.stop_listening(ec);
    std::vector<Hdl> open;  // terminate() calls the close handler, which erases from clients
    for (const auto& entry : m.clients) open.push_back(entry.first);
    for (const Hdl& h : open) {
      auto con = m.ws.get_con_from_hdl(h, ec);
      if (!ec) con->terminate(ec);
    }
    m.ws.stop();
  });
  if (s.thread.joinable()) {
    s.thread.join();
  } else {
    s.ws.stop();
  }
}

std::uint16_t FoxgloveServer::port() const {
  return impl_->bound_port;
}

const std::vector<Channel>& FoxgloveServer::channels() const {
  return impl_->channels;
}

bool FoxgloveServer::has_subscribers(std::uint32_t channel_id) const {
  const auto it = impl_->channel_index.find(channel_id);
  return it != impl_->channel_index.end() && impl_->subscribers[it->second].load() > 0;
}

void FoxgloveServer::send_message(std::uint32_t channel_id, std::uint64_t receive_ns, const std::uint8_t* bytes,
                                  std::size_t size) {
  Impl& s = *impl_;
  const auto it = s.channel_index.find(channel_id);
  if (!s.started.load() || s.stopped.load() || it == s.channel_index.end()) return;
  // Latched channels are kept even without subscribers (for the next subscription).
  if (!s.channels[it->second].latched && s.subscribers[it->second].load() == 0) return;
  // The server thread's backlog is bounded too: beyond one client queue's worth, samples are
  // dropped (counted) instead of piling up in the io_service.
  if (s.pending_bytes.load() + size > s.opts.max_queue_bytes) {
    s.samples_dropped.fetch_add(1);
    return;
  }
  s.pending_bytes.fetch_add(size);
  auto data = std::make_shared<std::vector<std::uint8_t>>(bytes, bytes + size);
  s.ws.get_io_service().post([this, channel_id, receive_ns, data] { impl_->relay(channel_id, receive_ns, data); });
}

FoxgloveServerStats FoxgloveServer::stats() const {
  const Impl& s = *impl_;
  FoxgloveServerStats st;
  st.connected = s.connected.load();
  st.accepted = s.accepted.load();
  st.refused = s.refused.load();
  st.dropped_slow = s.dropped_slow.load();
  st.bad_requests = s.bad_requests.load();
  st.messages_sent = s.messages_sent.load();
  st.samples_dropped = s.samples_dropped.load();
  st.unauthorized = s.unauthorized.load();
  return st;
}

}  // namespace regolith::live
