// The one mapping from an exception to the protocol error a client gets (proto/PROTOCOL.md,
// "Error codes"), for everything a session does: messages, scene loads, renders, encoding.
#pragma once

#include <exception>
#include <string>

namespace vismap::server {

class Library;

struct ErrorReply {
  std::string code;
  std::string message;
  bool fatal = false;
};

// e: the exception in flight (std::current_exception() in a catch block). doing: what failed,
// for messages without their own ("loading tet.obj", "rendering"). library: when set, its
// folder is removed from every message (clients never see server paths). scene: an InputError
// that names no file (a dicer's, the camera's) names this one instead of "<input>".
//   ProtoError        -> its code and fatal flag
//   InputError        -> to_string(kind) (e.g. "time_limit", "parse_error"), not fatal
//   DeviceError       -> device_error
//   std::bad_alloc    -> too_large ("out of memory while <doing>")
//   anything else     -> internal
ErrorReply error_reply(std::exception_ptr e, const std::string& doing,
                       const Library* library = nullptr, const std::string& scene = {});

}  // namespace vismap::server
