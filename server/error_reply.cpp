#include "server/error_reply.h"

#include <new>

#include "core/error.h"
#include "server/library.h"
#include "server/protocol.h"

namespace vismap::server {

ErrorReply error_reply(std::exception_ptr e, const std::string& doing, const Library* library,
                       const std::string& scene) {
  ErrorReply r;
  try {
    std::rethrow_exception(e);
  } catch (const ProtoError& x) {
    r = {x.code, x.what(), x.fatal};
  } catch (const InputError& x) {
    if (x.file().empty() && !scene.empty())
      r = {error_code(x),
           InputError(x.kind(), scene, x.mesh(), x.element(), x.index(), x.detail()).what(), false};
    else
      r = {error_code(x), x.what(), false};
  } catch (const DeviceError& x) {
    r = {code::device_error, x.what(), false};
  } catch (const std::bad_alloc&) {
    r = {code::too_large, "out of memory while " + doing, false};
  } catch (const std::exception& x) {
    r = {code::internal, doing + ": " + x.what(), false};
  } catch (...) {
    r = {code::internal, doing + ": unknown error", false};
  }
  if (library) r.message = library->hide_paths(std::move(r.message));
  return r;
}

}  // namespace vismap::server
