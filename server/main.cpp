// vismapd: the streaming server. See docs/SERVER.md and proto/PROTOCOL.md.
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <nlohmann/json.hpp>
#include <thread>

#include "core/pipeline.h"
#include "server/server.h"

int main(int argc, char** argv) {
  using namespace vismap::server;
  vismap::keep_freed_memory_for_reuse();
  Config cfg;
  try {
    std::string usage;
    if (!parse_args(cfg, argc, argv, usage)) {
      std::fputs(usage.c_str(), stdout);
      return 0;
    }
    // Test-only: every frame takes this much longer (the drain tests of the real binary need
    // a frame still running at SIGTERM). Not a config key; never set in deployment.
    if (const char* d = std::getenv("VISMAPD_TEST_FRAME_DELAY_S"); d && *d) {
      auto delay = std::chrono::duration<double>(std::atof(d));
      cfg.before_render = [delay](const vismap::RenderOptions&) {
        std::this_thread::sleep_for(delay);
      };
    }
    Server server(cfg);
    server.start();
    if (!server.run_until_signal()) {
      // The drain deadline passed with a frame still on the device: sessions were closed with
      // 1001 already; exit now rather than wait for the frame (and the Renderer) to finish.
      std::fflush(stderr);
      std::_Exit(0);
    }
    return 0;
  } catch (const std::exception& e) {
    nlohmann::json j = {{"level", "error"}, {"event", "fatal"}, {"message", e.what()}};
    std::fprintf(stderr, "%s\n",
                 j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
    return 1;
  }
}
