// What the parts of vismapd share (server.cpp: listener and lifecycle; http_session.cpp: plain
// HTTP and the upgrade; ws_session.cpp: the WebSocket session): the io_context, the pools, the
// render queue, the counters that hold connection and session slots, the session registry.
#pragma once

// clang-format off
// Boost 1.74 asio/awaitable.hpp uses std::exchange without <utility> (fails under C++20, g++ 12).
#include <utility>  // before any Boost.Asio header
// clang-format on

#include <atomic>
#include <boost/asio.hpp>
#include <chrono>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "server/config.h"
#include "server/library.h"
#include "server/metrics.h"
#include "server/render_queue.h"
#include "server/server.h"

namespace vismap::server {

namespace net = boost::asio;
using tcp = net::ip::tcp;

inline std::chrono::milliseconds seconds(double s) {
  return std::chrono::milliseconds(static_cast<int64_t>(s * 1000));
}

// What Server::stop asks of a live session (WsSession implements it; called from any thread).
class SessionHandle {
 public:
  virtual ~SessionHandle() = default;
  // No new work; close with shutting_down (1001) once the frame or load in flight is done.
  virtual void drain_async() = 0;
  // The drain deadline is near: shutting_down (1001) now, whatever is in flight.
  virtual void close_now_async() = 0;
};

// Open TCP connections, in all and per peer address (limits.max_connections and
// max_connections_per_address). Slots are taken before a byte is read.
class ConnectionCounter {
 public:
  // Returns false (and takes nothing) when either cap is reached.
  bool take(const std::string& address, uint32_t max_total, uint32_t max_per_address);
  void give_back(const std::string& address);
  uint32_t total() const { return total_; }

 private:
  std::atomic<uint32_t> total_{0};
  std::mutex mu_;
  std::map<std::string, uint32_t> per_address_;
};

// Holds one connection slot while the connection is open (moves from HTTP to WebSocket).
class ConnectionSlot {
 public:
  ConnectionSlot() = default;
  ConnectionSlot(ConnectionCounter& c, std::string address)
      : c_(&c), address_(std::move(address)) {}
  ConnectionSlot(ConnectionSlot&& o) noexcept
      : c_(std::exchange(o.c_, nullptr)), address_(std::move(o.address_)) {}
  ConnectionSlot& operator=(ConnectionSlot&&) = delete;
  ~ConnectionSlot() {
    if (c_) c_->give_back(address_);
  }

 private:
  ConnectionCounter* c_ = nullptr;
  std::string address_;
};

struct Server::Impl {
  Impl(Config c, RenderQueue::RendererFactory make);

  void accept();
  uint64_t add(const std::shared_ptr<SessionHandle>& s);
  void remove(uint64_t connection);
  size_t session_count();
  std::vector<std::shared_ptr<SessionHandle>> live_sessions();
  // Hands freed heap memory back to the kernel, off the network threads (see ws_session.cpp).
  void trim_memory();

  // Declared first, destroyed last: sessions (destroyed with the io_context's handlers) give
  // their slots back into these.
  Config cfg;
  Metrics metrics;
  Log log;
  Library library;
  std::string www;
  ConnectionCounter connections;
  std::atomic<bool> stopping{false};
  std::atomic<bool> stopped{false};
  std::atomic<int> trim_requests{0};
  std::mutex sessions_mu;
  std::map<uint64_t, std::weak_ptr<SessionHandle>> sessions;  // by connection id
  uint64_t next_connection = 1;

  net::io_context ioc;
  std::optional<net::executor_work_guard<net::io_context::executor_type>> work;
  tcp::acceptor acceptor{net::make_strand(ioc)};
  std::vector<std::thread> threads;
  // Work in flight on the pools, so stop() knows whether it may join them by the deadline.
  std::atomic<int> loads_in_flight{0}, encodes_in_flight{0};
  net::thread_pool load_pool;
  net::thread_pool encode_pool;
  // Declared last, destroyed first: its workers post into the pools above.
  RenderQueue queue;
};

// http_session.cpp: serves one accepted connection (health, metrics, viewer, upgrade).
void serve_http(tcp::socket&& socket, Server::Impl& srv, ConnectionSlot slot);

}  // namespace vismap::server
