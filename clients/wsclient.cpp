#include "clients/wsclient.h"

// clang-format off
// Boost 1.74 asio/awaitable.hpp uses std::exchange without <utility> (fails under C++20, g++ 12).
#include <utility>  // before any Boost.Asio header
// clang-format on

#include <boost/asio.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <deque>
#include <functional>
#include <optional>
#include <utility>

namespace vismap::client {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = net::ip::tcp;
using Clock = std::chrono::steady_clock;

static Clock::duration secs(double s) {
  return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
}

// Runs handlers until done() or the deadline. Returns done().
template <class F>
static bool run_until(net::io_context& ioc, F done, Clock::time_point deadline) {
  while (!done()) {
    auto now = Clock::now();
    if (now >= deadline) return false;
    ioc.restart();
    ioc.run_one_for(deadline - now);
  }
  return true;
}

Url parse_url(const std::string& url) {
  size_t p = url.find("://");
  if (p == std::string::npos) throw std::invalid_argument("URL needs a scheme: " + url);
  std::string rest = url.substr(p + 3);
  size_t slash = rest.find('/');
  std::string hostport = rest.substr(0, slash);
  Url u;
  u.target = slash == std::string::npos ? "/" : rest.substr(slash);
  size_t colon = hostport.rfind(':');
  if (colon == std::string::npos) {
    u.host = hostport;
    u.port = "80";
  } else {
    u.host = hostport.substr(0, colon);
    u.port = hostport.substr(colon + 1);
  }
  if (u.host.empty() || u.port.empty()) throw std::invalid_argument("bad URL: " + url);
  return u;
}

struct WsClient::Impl {
  net::io_context ioc;
  websocket::stream<beast::tcp_stream> ws{ioc};
  beast::flat_buffer buf;
  bool read_armed = false;
  bool deflate = false;
  std::deque<Message> inbox;
  std::optional<beast::error_code> read_error;

  void arm() {
    if (read_armed || read_error) return;
    read_armed = true;
    ws.async_read(buf, [this](beast::error_code ec, size_t) {
      read_armed = false;
      if (ec) {
        read_error = ec;
        return;
      }
      inbox.push_back({ws.got_binary(), beast::buffers_to_string(buf.data())});
      buf.consume(buf.size());
    });
  }

  void write(const std::string& s, bool binary, double timeout_s) {
    if (read_error) throw_closed();
    ws.binary(binary);
    std::optional<beast::error_code> result;
    ws.async_write(net::buffer(s), [&](beast::error_code ec, size_t) { result = ec; });
    if (!run_until(
            ioc, [&] { return result.has_value(); }, Clock::now() + secs(timeout_s))) {
      beast::get_lowest_layer(ws).cancel();
      run_until(
          ioc, [&] { return result.has_value(); }, Clock::now() + secs(1));
      throw Timeout("write timed out");
    }
    if (*result) {
      if (read_error) throw_closed();
      throw Closed(1006, result->message());
    }
  }

  [[noreturn]] void throw_closed() {
    if (*read_error == websocket::error::closed)
      throw Closed(ws.reason().code, std::string(ws.reason().reason.c_str()));
    throw Closed(1006, read_error->message());
  }
};

WsClient::WsClient() : impl_(std::make_unique<Impl>()) {}
WsClient::~WsClient() = default;

void WsClient::connect(const std::string& url, double timeout_s, bool permessage_deflate) {
  Url u = parse_url(url);
  auto deadline = Clock::now() + secs(timeout_s);
  tcp::resolver resolver(impl_->ioc);
  auto results = resolver.resolve(u.host, u.port);
  auto& tcp_layer = beast::get_lowest_layer(impl_->ws);
  tcp_layer.expires_at(deadline);
  std::optional<beast::error_code> result;
  tcp_layer.async_connect(results,
                          [&](beast::error_code ec, const tcp::endpoint&) { result = ec; });
  run_until(
      impl_->ioc, [&] { return result.has_value(); }, deadline + secs(1));
  if (!result || *result)
    throw std::runtime_error("connect " + u.host + ":" + u.port + ": " +
                             (result ? result->message() : "timeout"));
  tcp_layer.expires_never();
  beast::error_code ignored;
  tcp_layer.socket().set_option(tcp::no_delay(true), ignored);
  impl_->ws.set_option(
      websocket::stream_base::timeout{secs(timeout_s), websocket::stream_base::none(), false});
  impl_->ws.read_message_max(1ull << 30);
  if (permessage_deflate) {
    websocket::permessage_deflate pmd;
    pmd.client_enable = true;
    impl_->ws.set_option(pmd);
  }
  result.reset();
  websocket::response_type res;
  impl_->ws.async_handshake(res, u.host + ":" + u.port, u.target,
                            [&](beast::error_code ec) { result = ec; });
  if (!run_until(
          impl_->ioc, [&] { return result.has_value(); }, deadline + secs(1)))
    throw Timeout("handshake timed out");
  if (*result)
    throw std::runtime_error("WebSocket handshake with " + url + ": " + result->message());
  impl_->deflate =
      std::string(res[http::field::sec_websocket_extensions]).find("permessage-deflate") !=
      std::string::npos;
}

bool WsClient::deflate_negotiated() const {
  return impl_->deflate;
}

uint64_t tcp_bytes_received(int fd);  // tcp_bytes.cpp

uint64_t WsClient::wire_bytes_received() const {
  auto& s = impl_->ws.next_layer().socket();
  return s.is_open() ? tcp_bytes_received(s.native_handle()) : 0;
}

void WsClient::send_text(const std::string& s, double t) {
  impl_->write(s, false, t);
}
void WsClient::send_binary(const std::string& s, double t) {
  impl_->write(s, true, t);
}

Message WsClient::read(double timeout_s) {
  Impl& m = *impl_;
  if (m.inbox.empty()) {
    m.arm();
    run_until(
        m.ioc, [&] { return !m.inbox.empty() || m.read_error.has_value(); },
        Clock::now() + secs(timeout_s));
  }
  if (!m.inbox.empty()) {
    Message msg = std::move(m.inbox.front());
    m.inbox.pop_front();
    return msg;
  }
  if (m.read_error) m.throw_closed();
  throw Timeout("no message within " + std::to_string(timeout_s) + " s");
}

void WsClient::close(double timeout_s) {
  Impl& m = *impl_;
  if (m.read_error || !m.ws.is_open()) return drop();
  std::optional<beast::error_code> result;
  m.ws.async_close(websocket::close_code::normal, [&](beast::error_code ec) { result = ec; });
  run_until(
      m.ioc, [&] { return result.has_value(); }, Clock::now() + secs(timeout_s));
  drop();
}

void WsClient::drop() {
  beast::error_code ec;
  auto& s = beast::get_lowest_layer(impl_->ws).socket();
  s.shutdown(tcp::socket::shutdown_both, ec);
  s.close(ec);
  impl_->ioc.restart();
  impl_->ioc.poll();
}

HttpResponse http_get(const std::string& host, const std::string& port, const std::string& target,
                      double timeout_s) {
  net::io_context ioc;
  beast::tcp_stream stream(ioc);
  tcp::resolver resolver(ioc);
  auto deadline = Clock::now() + secs(timeout_s);
  stream.expires_at(deadline);
  std::optional<beast::error_code> result;
  stream.async_connect(resolver.resolve(host, port),
                       [&](beast::error_code ec, const tcp::endpoint&) { result = ec; });
  run_until(
      ioc, [&] { return result.has_value(); }, deadline + secs(1));
  if (!result || *result)
    throw std::runtime_error("connect: " + (result ? result->message() : std::string("timeout")));
  http::request<http::empty_body> req(http::verb::get, target, 11);
  req.set(http::field::host, host);
  req.keep_alive(false);
  result.reset();
  http::async_write(stream, req, [&](beast::error_code ec, size_t) { result = ec; });
  run_until(
      ioc, [&] { return result.has_value(); }, deadline + secs(1));
  if (!result || *result) throw std::runtime_error("HTTP write failed");
  beast::flat_buffer buf;
  http::response<http::string_body> res;
  result.reset();
  http::async_read(stream, buf, res, [&](beast::error_code ec, size_t) { result = ec; });
  run_until(
      ioc, [&] { return result.has_value(); }, deadline + secs(1));
  if (!result || *result) throw std::runtime_error("HTTP read failed");
  return {static_cast<int>(res.result_int()), std::string(res[http::field::content_type]),
          res.body()};
}

double wait_for_server_close(const std::string& host, const std::string& port,
                             const std::string& bytes, double timeout_s) {
  net::io_context ioc;
  tcp::socket s(ioc);
  tcp::resolver resolver(ioc);
  net::connect(s, resolver.resolve(host, port));
  auto t0 = Clock::now();
  if (!bytes.empty()) net::write(s, net::buffer(bytes));
  char buf[4096];
  bool closed = false;
  std::function<void(beast::error_code, size_t)> on_read = [&](beast::error_code ec, size_t) {
    if (ec) {
      closed = true;
      return;
    }
    s.async_read_some(net::buffer(buf), on_read);
  };
  s.async_read_some(net::buffer(buf), on_read);
  if (!run_until(
          ioc, [&] { return closed; }, t0 + secs(timeout_s)))
    return -1;
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

}  // namespace vismap::client
