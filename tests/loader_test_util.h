// Helpers for the loader tests: a temporary folder to write (bad) files into, and an assertion
// that a load fails with a given error kind and a message naming the file and the element.
#pragma once

#include <gtest/gtest.h>
#include <stdlib.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "core/error.h"
#include "core/scene.h"

namespace vismap::test {

class TempDir {
 public:
  TempDir() {
    std::string tmpl = (std::filesystem::temp_directory_path() / "vismap_loaders_XXXXXX").string();
    dir_ = mkdtemp(tmpl.data()) ? tmpl : std::string();
  }
  ~TempDir() {
    std::error_code ec;
    if (!dir_.empty()) std::filesystem::remove_all(dir_, ec);
  }
  std::string write(const std::string& name, const std::string& bytes) const {
    std::string path = dir_ + "/" + name;
    std::ofstream(path, std::ios::binary) << bytes;
    return path;
  }
  const std::string& path() const { return dir_; }

 private:
  std::string dir_;
};

inline std::string read_bytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

// Loads `path`, expects InputError of `kind` whose message contains `file` and every `parts`.
inline void expect_error(const std::string& path, InputErrorKind kind,
                         const std::vector<std::string>& parts, const LoadOptions& opts = {}) {
  try {
    Scene s = load_scene(path, opts);
    ADD_FAILURE() << path << ": loaded " << s.triangle_count() << " triangles, expected "
                  << to_string(kind);
  } catch (const InputError& e) {
    EXPECT_EQ(e.kind(), kind) << e.what();
    std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << "message does not name the file: " << what;
    for (const std::string& p : parts)
      EXPECT_NE(what.find(p), std::string::npos) << "message lacks '" << p << "': " << what;
  }
}

inline std::string data_dir() { return std::string(VISMAP_SOURCE_DIR) + "/data"; }
inline std::string shared_dir() { return VISMAP_SHARED_DATA_DIR; }
inline bool have_shared() { return std::filesystem::exists(shared_dir() + "/SOURCES.md"); }

}  // namespace vismap::test
