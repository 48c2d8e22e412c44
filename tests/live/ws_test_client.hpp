#pragma once
// A minimal blocking WebSocket client for the tests of the Foxglove server, written against
// RFC 6455 with plain sockets so that a test controls every byte: garbage frames, and a client
// that completes the handshake and then never reads (small receive buffer).
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

namespace regolith::live::testing {

struct Frame {
  int opcode = 0;  // 1 text, 2 binary, 8 close
  std::string payload;
};

class WsClient {
 public:
  /// Connects to 127.0.0.1:port and upgrades `path` with the given subprotocol (none when empty);
  /// `rcvbuf` > 0 sets SO_RCVBUF before connecting. ok() tells whether the server accepted (HTTP 101).
  WsClient(std::uint16_t port, const std::string& subprotocol, int rcvbuf = 0, const std::string& path = "/") {
    fd_ = socket(AF_INET, SOCK_STREAM, 0);
    if (rcvbuf > 0) setsockopt(fd_, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) return;
    const std::string req = "GET " + path + " HTTP/1.1\r\nHost: 127.0.0.1:" + std::to_string(port) +
                            "\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
                            "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n" +
                            (subprotocol.empty() ? "" : "Sec-WebSocket-Protocol: " + subprotocol + "\r\n") + "\r\n";
    if (!write_all(req)) return;
    std::string resp;
    char c = 0;
    while (resp.find("\r\n\r\n") == std::string::npos) {
      if (!read_exact(&c, 1)) return;
      resp.push_back(c);
    }
    response_ = resp;
    ok_ = resp.rfind("HTTP/1.1 101", 0) == 0;
  }
  ~WsClient() {
    if (fd_ >= 0) close(fd_);
  }
  WsClient(const WsClient&) = delete;
  WsClient& operator=(const WsClient&) = delete;

  bool ok() const { return ok_; }
  const std::string& response() const { return response_; }

  /// Sends one masked frame (FIN set).
  bool send(int opcode, const std::string& payload) {
    std::string f;
    f.push_back(static_cast<char>(0x80 | opcode));
    const std::size_t n = payload.size();
    if (n < 126) {
      f.push_back(static_cast<char>(0x80 | n));
    } else if (n < 65536) {
      f.push_back(static_cast<char>(0x80 | 126));
      f.push_back(static_cast<char>((n >> 8) & 0xff));
      f.push_back(static_cast<char>(n & 0xff));
    } else {
      f.push_back(static_cast<char>(0x80 | 127));
      for (int i = 7; i >= 0; --i) f.push_back(static_cast<char>((static_cast<std::uint64_t>(n) >> (8 * i)) & 0xff));
    }
    const char mask[4] = {0x12, 0x34, 0x56, 0x78};
    f.append(mask, 4);
    for (std::size_t i = 0; i < n; ++i) f.push_back(static_cast<char>(payload[i] ^ mask[i % 4]));
    return write_all(f);
  }
  bool send_text(const std::string& s) { return send(1, s); }

  /// Reads one frame, waiting up to `timeout_ms`; nullopt on timeout, error or end of stream.
  std::optional<Frame> read(int timeout_ms = 5000) {
    unsigned char h[2];
    if (!wait_readable(timeout_ms) || !read_exact(h, 2)) return std::nullopt;
    Frame f;
    f.opcode = h[0] & 0x0f;
    std::uint64_t n = h[1] & 0x7f;
    if (n == 126) {
      unsigned char e[2];
      if (!read_exact(e, 2)) return std::nullopt;
      n = (static_cast<std::uint64_t>(e[0]) << 8) | e[1];
    } else if (n == 127) {
      unsigned char e[8];
      if (!read_exact(e, 8)) return std::nullopt;
      n = 0;
      for (int i = 0; i < 8; ++i) n = (n << 8) | e[i];
    }
    f.payload.resize(n);
    if (n > 0 && !read_exact(f.payload.data(), n)) return std::nullopt;
    return f;
  }

 private:
  bool wait_readable(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    return poll(&p, 1, timeout_ms) > 0;
  }
  bool write_all(const std::string& s) {
    std::size_t off = 0;
    while (off < s.size()) {
      const ssize_t w = ::send(fd_, s.data() + off, s.size() - off, MSG_NOSIGNAL);
      if (w <= 0) return false;
      off += static_cast<std::size_t>(w);
    }
    return true;
  }
  bool read_exact(void* dst, std::size_t n) {
    auto* p = static_cast<char*>(dst);
    while (n > 0) {
      if (!wait_readable(10000)) return false;
      const ssize_t r = recv(fd_, p, n, 0);
      if (r <= 0) return false;
      p += r;
      n -= static_cast<std::size_t>(r);
    }
    return true;
  }

  int fd_ = -1;
  bool ok_ = false;
  std::string response_;
};

}  // namespace regolith::live::testing
