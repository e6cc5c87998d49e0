// A small synchronous WebSocket/HTTP client on Beast, with a timeout on every call. Used by
// vismap-client, bench/server_bench and the server tests; one heavy TU (wsclient.cpp) for all.
#pragma once

#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>

namespace vismap::client {

struct Url {
  std::string host, port, target;
};
// ws://HOST:PORT/PATH (also http://). Throws std::invalid_argument.
Url parse_url(const std::string& url);

struct Message {
  bool binary = false;
  std::string data;
};

// The peer closed the WebSocket (code: its close code, 1006 when the TCP connection just ended).
struct Closed : std::runtime_error {
  Closed(int c, const std::string& reason)
      : std::runtime_error("closed " + std::to_string(c) + " " + reason), code(c) {}
  int code;
};

struct Timeout : std::runtime_error {
  using std::runtime_error::runtime_error;
};

class WsClient {
 public:
  WsClient();
  ~WsClient();
  WsClient(const WsClient&) = delete;
  WsClient& operator=(const WsClient&) = delete;

  // Throws std::runtime_error (connect or handshake failed, e.g. HTTP 404), or Timeout.
  // permessage_deflate: offer the extension (RFC 7692) in the upgrade; the server may decline.
  void connect(const std::string& url, double timeout_s = 5, bool permessage_deflate = false);
  // The server's upgrade response accepted permessage-deflate (messages travel deflated).
  bool deflate_negotiated() const;
  // Bytes the TCP connection has received so far, headers and framing included (Linux TCP_INFO;
  // 0 where unknown): the wire cost of messages, after any permessage-deflate.
  uint64_t wire_bytes_received() const;
  void send_text(const std::string& s, double timeout_s = 10);
  void send_binary(const std::string& s, double timeout_s = 10);
  // Next message. Throws Timeout (the read stays armed: a later read() gets that message),
  // or Closed.
  Message read(double timeout_s = 10);
  // Sends a close frame and waits for the peer's (bounded). Never throws.
  void close(double timeout_s = 2);
  // Drops the TCP connection without a close handshake (a client that vanishes).
  void drop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

struct HttpResponse {
  int status = 0;
  std::string content_type, body;
};
HttpResponse http_get(const std::string& host, const std::string& port, const std::string& target,
                      double timeout_s = 5);

// Opens a TCP connection, sends `bytes` (may be empty) and waits until the server closes it.
// Returns the seconds waited, or -1 when the server kept it open for timeout_s.
double wait_for_server_close(const std::string& host, const std::string& port,
                             const std::string& bytes, double timeout_s);

}  // namespace vismap::client
