// vismapd: the streaming server. See docs/SERVER.md and proto/PROTOCOL.md.
#include <cstdio>
#include <cstdlib>
#include <exception>

#include <nlohmann/json.hpp>

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
