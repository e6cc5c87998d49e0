#include "server/library.h"

#include <sys/stat.h>

#include <climits>
#include <cstdlib>

#include "server/protocol.h"

namespace vismap::server {

static std::string real_path(const std::string& p) {
  char buf[PATH_MAX];
  return ::realpath(p.c_str(), buf) ? std::string(buf) : std::string();
}

static std::string without_slash(std::string p) {
  while (p.size() > 1 && p.back() == '/') p.pop_back();
  return p;
}

Library::Library(const std::string& root) : configured_(without_slash(root)) {
  if (configured_.empty()) return;
  root_ = real_path(configured_);
  if (root_.empty()) root_ = configured_;  // missing folder: every name is then not found
}

std::string Library::resolve(const std::string& name) const {
  if (!enabled()) throw ProtoError(code::file_not_found, "server has no scene library");
  if (!safe_library_name(name))
    throw ProtoError(code::bad_message, "library scene names are relative paths without '..'");
  std::string shown = name.size() > 200 ? name.substr(0, 200) + "..." : name;
  std::string path = real_path(root_ + "/" + name);
  if (path.empty()) throw ProtoError(code::file_not_found, shown + ": not in the library");
  if (path.compare(0, root_.size() + 1, root_ + "/") != 0)
    throw ProtoError(code::file_not_found, shown + ": leads out of the library; refused");
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    throw ProtoError(code::file_not_found, shown + ": not a regular file; refused");
  return path;
}

std::string Library::hide_paths(std::string message) const {
  for (const std::string& dir : {root_, configured_}) {
    if (dir.empty()) continue;
    for (size_t at; (at = message.find(dir + "/")) != std::string::npos;)
      message.erase(at, dir.size() + 1);
    for (size_t at; (at = message.find(dir)) != std::string::npos;)
      message.replace(at, dir.size(), "<library>");
  }
  return message;
}

}  // namespace vismap::server
