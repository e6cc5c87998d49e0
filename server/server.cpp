// vismapd's listener and lifecycle: binding, the accept loop with the connection caps, the
// session registry, and the graceful stop that keeps its deadline. HTTP is in http_session.cpp,
// the WebSocket session in ws_session.cpp, the error mapping in error_reply.cpp.
#include "server/server.h"

#include <malloc.h>
#include <unistd.h>

#include <boost/beast/core.hpp>
#include <csignal>
#include <cstdio>

#include "core/pipeline.h"
#include "core/util/clock.h"
#include "server/server_impl.h"

#ifndef VISMAP_WWW_DIR
#define VISMAP_WWW_DIR ""
#endif

namespace vismap::server {

namespace beast = boost::beast;

bool ConnectionCounter::take(const std::string& address, uint32_t max_total,
                             uint32_t max_per_address) {
  std::lock_guard lk(mu_);
  if (total_ >= max_total) return false;
  uint32_t& n = per_address_[address];
  if (max_per_address && n >= max_per_address) {
    if (n == 0) per_address_.erase(address);
    return false;
  }
  ++n;
  ++total_;
  return true;
}

void ConnectionCounter::give_back(const std::string& address) {
  std::lock_guard lk(mu_);
  auto it = per_address_.find(address);
  if (it != per_address_.end() && --it->second == 0) per_address_.erase(it);
  --total_;
}

Server::Impl::Impl(Config c, RenderQueue::RendererFactory make)
    : cfg(std::move(c)),
      library(cfg.library),
      www(cfg.www.empty() ? std::string(VISMAP_WWW_DIR) : cfg.www),
      load_pool(cfg.load_threads),
      encode_pool(cfg.encode_threads),
      queue(
          cfg.renderers,
          make ? std::move(make) : [dev = cfg.device] { return std::make_unique<Renderer>(dev); }) {
  log.set_level(cfg.log_level);
}

uint64_t Server::Impl::add(const std::shared_ptr<SessionHandle>& s) {
  std::lock_guard lk(sessions_mu);
  uint64_t id = next_connection++;
  sessions[id] = s;
  return id;
}

void Server::Impl::remove(uint64_t connection) {
  std::lock_guard lk(sessions_mu);
  sessions.erase(connection);
}

size_t Server::Impl::session_count() {
  std::lock_guard lk(sessions_mu);
  return sessions.size();
}

std::vector<std::shared_ptr<SessionHandle>> Server::Impl::live_sessions() {
  std::vector<std::shared_ptr<SessionHandle>> live;
  std::lock_guard lk(sessions_mu);
  for (auto& [id, w] : sessions)
    if (auto p = w.lock()) live.push_back(p);
  return live;
}

static double resident_mib() {
  long pages = 0, resident = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld %ld", &pages, &resident) != 2) resident = 0;
    std::fclose(f);
  }
  return static_cast<double>(resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / 1048576.0;
}

// keep_freed_memory_for_reuse() (main) keeps freed blocks in the heap, and CPU devices keep
// their freed host blocks of 32 MiB and more, so frames do not pay page faults again; but then
// one big upload or frame stays resident for good (760 MB after one spike). Sessions that saw a
// big message, frame, scene or frame's device memory call this when they end, and so do a big
// upload when its load is done and a request refused for its size or time (ws_session.cpp):
// release_freed_memory() unmaps the kept host blocks and malloc_trim(0) returns every arena's free
// pages (not a thread arena's top: see the test MemoryReturnedAfterABigUpload). It runs on the
// load pool, one at a time, since it walks the heap under the arenas' locks; requests meanwhile
// make it run once more.
void Server::Impl::trim_memory() {
  if (trim_requests.fetch_add(1) > 0) return;  // a trim is queued or running: it runs again
  loads_in_flight++;
  net::post(load_pool, [this] {
    int seen = 0;
    do {  // until no request came in during the last trim
      seen = trim_requests.load();
      double before = resident_mib();
      release_freed_memory();
      log.info("memory_trimmed", {{"rss_mib_before", before}, {"rss_mib_after", resident_mib()}});
    } while (!trim_requests.compare_exchange_strong(seen, 0));
    loads_in_flight--;
  });
}

void Server::Impl::accept() {
  acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket s) {
    if (ec) {
      if (ec == net::error::operation_aborted || stopping) return;
      log.warn("accept_error", {{"message", ec.message()}});
    } else {
      beast::error_code ignored;
      auto ep = s.remote_endpoint(ignored);
      std::string address = ignored ? std::string("?") : ep.address().to_string();
      const Limits& L = cfg.limits;
      if (!connections.take(address, L.max_connections, L.max_connections_per_address)) {
        metrics.sessions_refused++;  // over a cap: closed at once, before reading a byte
        s.close(ignored);
      } else {
        s.set_option(tcp::no_delay(true), ignored);  // frames are latency-bound: no Nagle delay
        serve_http(std::move(s), *this, ConnectionSlot(connections, address));
      }
    }
    if (!stopping) accept();
  });
}

Server::Server(Config cfg, RenderQueue::RendererFactory make) {
  validate(cfg, "config");
  impl_ = std::make_unique<Impl>(std::move(cfg), std::move(make));
}

Server::~Server() {
  stop();
}

Metrics& Server::metrics() {
  return impl_->metrics;
}
const Config& Server::config() const {
  return impl_->cfg;
}

uint16_t Server::start() {
  Impl& s = *impl_;
  beast::error_code ec;
  auto addr = net::ip::make_address(s.cfg.address, ec);
  if (ec) throw std::runtime_error("bad address '" + s.cfg.address + "'");
  tcp::endpoint ep(addr, s.cfg.port);
  s.acceptor.open(ep.protocol(), ec);
  if (!ec) s.acceptor.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) s.acceptor.bind(ep, ec);
  if (!ec) s.acceptor.listen(net::socket_base::max_listen_connections, ec);
  if (ec)
    throw std::runtime_error("cannot listen on " + s.cfg.address + ":" +
                             std::to_string(s.cfg.port) + ": " + ec.message());
  uint16_t port = s.acceptor.local_endpoint().port();
  s.work.emplace(s.ioc.get_executor());
  s.accept();
  for (uint32_t i = 0; i < s.cfg.io_threads; ++i) s.threads.emplace_back([&s] { s.ioc.run(); });
  s.log.info("listening", {{"address", s.cfg.address},
                           {"port", port},
                           {"renderers", s.cfg.renderers},
                           {"library", s.cfg.library},
                           {"auth", !s.cfg.token.empty()}});
  return port;
}

// The deadline is drain_timeout_s from the call, and stop() returns by it (issue 15, bug 7: a
// 26 s frame had held the process 16.7 s past a 3 s drain, and sessions saw only EOF):
//  1. the listener closes; each session is asked to drain (close 1001 once its frame or load is
//     done; idle sessions close at once);
//  2. a little before the deadline (a quarter of the drain, at most 1 s), sessions still busy
//     get shutting_down and close 1001 at once, whatever is in flight;
//  3. at the deadline the network threads stop. The pools and render workers are joined only
//     when idle: a frame still on the device is left behind, and stop() returns false so the
//     process can exit without waiting for it (main does; destroying the Server waits).
bool Server::stop() {
  Impl& s = *impl_;
  if (s.stopped.exchange(true)) return true;
  if (s.threads.empty()) {
    s.queue.stop();
    return true;
  }
  s.stopping = true;
  s.log.info("stopping", {{"sessions", s.metrics.sessions_active.load()}});
  net::post(s.acceptor.get_executor(), [&s] {
    beast::error_code ec;
    s.acceptor.close(ec);
  });
  double drain = std::max(0.0, s.cfg.drain_timeout_s);
  auto deadline = Clock::now() + seconds(drain);
  auto force_at = deadline - seconds(std::min(1.0, drain / 4));
  auto wait_sessions = [&](Clock::time_point until) {
    while (s.session_count() > 0 && Clock::now() < until)
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
  };
  for (auto& p : s.live_sessions()) p->drain_async();
  wait_sessions(force_at);
  size_t forced = s.session_count();
  if (forced > 0) {
    for (auto& p : s.live_sessions()) p->close_now_async();
    wait_sessions(deadline);
  }
  s.work.reset();
  s.ioc.stop();
  for (auto& t : s.threads) t.join();
  s.threads.clear();
  bool idle = s.queue.drain(0) && s.loads_in_flight == 0 && s.encodes_in_flight == 0;
  if (idle) {
    s.queue.stop();
    s.load_pool.join();
    s.encode_pool.join();
  }
  s.log.info("stopped", {{"frames", s.metrics.frames.load()},
                         {"forced_closes", forced},
                         {"work_left_running", !idle}});
  return idle;
}

bool Server::run_until_signal() {
  net::io_context sig_ioc;
  net::signal_set signals(sig_ioc, SIGINT, SIGTERM);
  signals.async_wait([&](beast::error_code, int sig) {
    impl_->log.info("signal", {{"signal", sig}});
  });
  sig_ioc.run();
  return stop();
}

}  // namespace vismap::server
