// The scene library: a folder of files clients may open by name (proto/PROTOCOL.md, `library`).
// A name is resolved with realpath and must stay inside the folder and be a regular file, so a
// symlink out of the library, a FIFO or a device is refused; messages name only the library-
// relative name, never a server path.
#pragma once

#include <string>

namespace vismap::server {

class Library {
 public:
  // root: the configured folder; empty: no library.
  explicit Library(const std::string& root);

  bool enabled() const { return !configured_.empty(); }
  // The folder as realpath resolved it (what LoadOptions::confine_to gets).
  const std::string& root() const { return root_; }

  // The real path of `name` inside the library. Throws ProtoError: bad_message for a name that
  // is not a plain relative path, file_not_found when it does not resolve to a regular file
  // inside the library. Never blocks on a FIFO (it is stat-ed, not opened).
  std::string resolve(const std::string& name) const;

  // `message` with the library's folder (as configured and as resolved) removed, so a loader's
  // error shows library-relative names only.
  std::string hide_paths(std::string message) const;

 private:
  std::string configured_, root_;
};

}  // namespace vismap::server
