// vismapd: WebSocket sessions (proto/PROTOCOL.md), /health, /metrics and the web viewer on one
// port, on Boost.Asio + Beast. Sessions share the device through a RenderQueue.
#pragma once

#include <cstdint>
#include <memory>

#include "server/config.h"
#include "server/metrics.h"
#include "server/render_queue.h"

namespace vismap::server {

class Server {
 public:
  // make: creates one Renderer per render worker; the default builds Renderer(cfg.device).
  explicit Server(Config cfg, RenderQueue::RendererFactory make = {});
  ~Server();  // stop()
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  // Binds and starts serving on background threads. Returns the bound port (cfg.port 0 picks one).
  // Throws std::runtime_error when the address cannot be bound.
  uint16_t start();
  // Graceful stop: refuses new connections and sessions, lets frames in flight finish and be
  // sent, closes sessions with "going away" (1001), then stops the threads; returns within
  // drain_timeout_s. Returns false when a render, load or encode was still running at the
  // deadline: it is left behind (destroying the Server waits for it; a process may just exit).
  bool stop();
  // Blocks until SIGINT or SIGTERM, then returns stop().
  bool run_until_signal();

  Metrics& metrics();
  const Config& config() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace vismap::server
