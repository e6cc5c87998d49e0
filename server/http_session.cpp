// Plain HTTP on the WebSocket port: GET /health, /metrics, the viewer's static files; an upgrade
// request hands the connection (and its slot) to a WebSocket session.
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cctype>
#include <cstring>
#include <nlohmann/json.hpp>

#include "server/protocol.h"
#include "server/server_impl.h"
#include "server/ws_session.h"

namespace vismap::server {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using nlohmann::json;

namespace {

const char* mime(const std::string& path) {
  auto ends = [&](const char* e) {
    size_t n = strlen(e);
    return path.size() >= n && path.compare(path.size() - n, n, e) == 0;
  };
  if (ends(".html")) return "text/html; charset=utf-8";
  if (ends(".js")) return "text/javascript";
  if (ends(".css")) return "text/css";
  if (ends(".svg")) return "image/svg+xml";
  if (ends(".json")) return "application/json";
  return "application/octet-stream";
}

// A file name the viewer folder may serve: [A-Za-z0-9._-], not starting with '.'.
bool servable(const std::string& name) {
  if (name.empty() || name.size() >= 100 || name[0] == '.') return false;
  for (char ch : name)
    if (!std::isalnum(static_cast<unsigned char>(ch)) && ch != '.' && ch != '-' && ch != '_')
      return false;
  return true;
}

bool websocket_target(const std::string& t) {
  return t == "/" || t == "/ws" || t.rfind("/?", 0) == 0 || t.rfind("/ws?", 0) == 0;
}

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& s, Server::Impl& srv, ConnectionSlot slot)
      : slot_(std::move(slot)), stream_(std::move(s)), srv_(srv) {}
  void run() {
    net::dispatch(stream_.get_executor(),
                  beast::bind_front_handler(&HttpSession::read, shared_from_this()));
  }

 private:
  void read() {
    parser_.emplace();
    parser_->header_limit(16 * 1024);
    parser_->body_limit(srv_.cfg.limits.max_control_bytes);
    stream_.expires_after(seconds(srv_.cfg.limits.handshake_timeout_s));
    http::async_read(stream_, buf_, *parser_,
                     beast::bind_front_handler(&HttpSession::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, size_t) {
    if (ec) {
      beast::error_code ec2;
      stream_.socket().shutdown(tcp::socket::shutdown_both, ec2);
      return;
    }
    auto& req = parser_->get();
    std::string target(req.target());
    if (websocket::is_upgrade(req)) {
      if (!websocket_target(target))
        return respond(http::status::not_found, "text/plain", "WebSocket endpoint is / or /ws\n");
      return start_ws_session(stream_.release_socket(), parser_->release(), srv_, std::move(slot_));
    }
    srv_.metrics.http_requests++;
    if (req.method() != http::verb::get && req.method() != http::verb::head)
      return respond(http::status::method_not_allowed, "text/plain", "only GET\n");
    std::string path = target.substr(0, target.find('?'));
    if (path == "/health") {
      json j = {{"status", srv_.stopping ? "stopping" : "ok"},
                {"sessions", srv_.metrics.sessions_active.load()},
                {"protocol", kMaxProtocolVersion},
                {"protocols", [] {
                   json a = json::array();
                   for (int v = kMinProtocolVersion; v <= kMaxProtocolVersion; ++v) a.push_back(v);
                   return a;
                 }()}};
      return respond(srv_.stopping ? http::status::service_unavailable : http::status::ok,
                     "application/json", j.dump() + "\n");
    }
    if (path == "/metrics")
      return respond(http::status::ok, "text/plain; version=0.0.4", srv_.metrics.prometheus());
    if (path == "/") path = "/index.html";
    std::string name = path.substr(1);
    if (!srv_.www.empty() && servable(name)) {
      try {
        return respond(http::status::ok, mime(name), read_file(srv_.www + "/" + name));
      } catch (const std::exception&) {
      }
    }
    respond(http::status::not_found, "text/plain", "not found\n");
  }

  void respond(http::status st, const char* type, std::string body) {
    auto res = std::make_shared<http::response<http::string_body>>(st, parser_->get().version());
    res->set(http::field::server, "vismapd");
    res->set(http::field::content_type, type);
    res->set(http::field::cache_control, "no-store");
    res->keep_alive(parser_->get().keep_alive() && !srv_.stopping);
    if (parser_->get().method() != http::verb::head) res->body() = std::move(body);
    res->prepare_payload();
    http::async_write(stream_, *res,
                      [self = shared_from_this(), res](beast::error_code ec, size_t) {
                        if (ec) return;
                        if (!res->keep_alive()) {
                          beast::error_code ec2;
                          self->stream_.socket().shutdown(tcp::socket::shutdown_send, ec2);
                          return;
                        }
                        self->read();
                      });
  }

  ConnectionSlot slot_;
  beast::tcp_stream stream_;
  beast::flat_buffer buf_;
  std::optional<http::request_parser<http::string_body>> parser_;
  Server::Impl& srv_;
};

}  // namespace

void serve_http(tcp::socket&& socket, Server::Impl& srv, ConnectionSlot slot) {
  std::make_shared<HttpSession>(std::move(socket), srv, std::move(slot))->run();
}

}  // namespace vismap::server
