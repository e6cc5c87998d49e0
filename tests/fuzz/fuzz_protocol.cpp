// libFuzzer target for the protocol parser (server/protocol.cpp): any bytes a client sends as a
// text message must give a Request or a ProtoError, never a crash, hang or other exception.
// Build and run: scripts/fuzz_protocol.sh [SECONDS]
#include <cstddef>
#include <cstdint>
#include <string>

#include "server/protocol.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  std::string text(reinterpret_cast<const char*>(data), size);
  try {
    vismap::server::Request r = vismap::server::parse_request(text, 1 << 16, 8192);
    if (auto* c = std::get_if<vismap::server::CameraRequest>(&r)) {
      vismap::Camera cam;
      c->apply_to(cam);
    }
  } catch (const vismap::server::ProtoError& e) {
    if (e.code.empty()) __builtin_trap();
  }
  bool ok = false;
  vismap::server::base64_decode(text, ok);
  vismap::server::safe_library_name(text);
  return 0;
}
