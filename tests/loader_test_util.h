// Helpers for the loader tests: a temporary folder to write (bad) files into, and an assertion
// that a load fails with a given error kind and a message naming the file and the element.
#pragma once

#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <thread>
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

// Runs `fn` in a child process, so that a load that hangs (a loop without end, a FIFO) fails the
// test instead of stopping the suite, and so that the child's peak memory is its own.
// `fn` returns "" when its checks pass, else what failed. Returns the failure ("" when none) and
// the child's peak RSS in KiB (getrusage's ru_maxrss, from wait4).
struct ChildResult {
  std::string failure;
  long max_rss_kib = 0;
};
inline ChildResult run_in_child(const std::function<std::string()>& fn, double seconds) {
  int fds[2];
  if (pipe(fds) != 0) return {"pipe failed", 0};
  pid_t pid = fork();
  if (pid < 0) return {"fork failed", 0};
  if (pid == 0) {
    close(fds[0]);
    std::string msg;
    try {
      msg = fn();
    } catch (const std::exception& e) {
      msg = std::string("unexpected exception: ") + e.what();
    }
    if (!msg.empty() && write(fds[1], msg.data(), msg.size()) < 0) _exit(2);
    _exit(msg.empty() ? 0 : 1);
  }
  close(fds[1]);
  auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  struct rusage ru {};
  pid_t done = 0;
  while ((done = wait4(pid, &status, WNOHANG, &ru)) == 0 &&
         std::chrono::steady_clock::now() < deadline)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ChildResult r;
  if (done == 0) {
    kill(pid, SIGKILL);
    wait4(pid, &status, 0, &ru);
    r.failure = "did not finish within " + std::to_string(seconds) + " s (killed)";
  } else {
    char buf[4096];
    ssize_t n;
    while ((n = read(fds[0], buf, sizeof buf)) > 0) r.failure.append(buf, size_t(n));
    if (r.failure.empty() && !(WIFEXITED(status) && WEXITSTATUS(status) == 0))
      r.failure = "child ended with status " + std::to_string(status);
  }
  close(fds[0]);
  r.max_rss_kib = ru.ru_maxrss;
  return r;
}

// The failure text of a load of `path` that should throw InputError of `kind` whose message
// contains every `parts` ("" when it does), for run_in_child.
inline std::string error_failure(const std::string& path, InputErrorKind kind,
                                 const std::vector<std::string>& parts,
                                 const LoadOptions& opts = {}) {
  try {
    Scene s = load_scene(path, opts);
    return path + ": loaded " + std::to_string(s.triangle_count()) + " triangles, expected " +
           to_string(kind);
  } catch (const InputError& e) {
    std::string what = e.what();
    if (e.kind() != kind)
      return "kind " + std::string(to_string(e.kind())) + ", expected " + to_string(kind) + ": " +
             what;
    for (const std::string& p : parts)
      if (what.find(p) == std::string::npos) return "message lacks '" + p + "': " + what;
  }
  return "";
}

// expect_error in a child that must finish within `seconds`.
inline void expect_error_within(double seconds, const std::string& path, InputErrorKind kind,
                                const std::vector<std::string>& parts,
                                const LoadOptions& opts = {}) {
  ChildResult r = run_in_child([&] { return error_failure(path, kind, parts, opts); }, seconds);
  EXPECT_EQ(r.failure, "") << path;
}

inline std::string data_dir() {
  return std::string(VISMAP_SOURCE_DIR) + "/data";
}
inline std::string shared_dir() {
  return VISMAP_SHARED_DATA_DIR;
}
inline bool have_shared() {
  return std::filesystem::exists(shared_dir() + "/SOURCES.md");
}

}  // namespace vismap::test
