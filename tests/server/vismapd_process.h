// vismapd as a child process, for the server tests of what only the real binary does
// (test_server.cpp, test_limits.cpp): main's allocator settings, signals, the process's memory.
#pragma once

#include <signal.h>
#include <sys/types.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace {

using nlohmann::json;

// vismapd as a child process (VISMAPD_PATH), for what only the real binary does: main's
// keep_freed_memory_for_reuse(), signals. Its log (stderr) is read until the listening line.
class Vismapd {
 public:
  explicit Vismapd(const std::vector<std::string>& args) {
    int fds[2];
    if (::pipe(fds) != 0) throw std::runtime_error("pipe");
    pid_ = ::fork();
    if (pid_ == 0) {
      ::dup2(fds[1], 2);
      ::close(fds[0]);
      std::vector<char*> argv{const_cast<char*>(VISMAPD_PATH)};
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(VISMAPD_PATH, argv.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    log_ = ::fdopen(fds[0], "r");
    char line[4096];
    while (std::fgets(line, sizeof line, log_)) {
      json j = json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.value("event", "") == "listening") {
        port_ = std::to_string(j["port"].get<int>());
        break;
      }
    }
    if (port_.empty()) throw std::runtime_error("vismapd did not start");
    drain_ = std::thread([this] {  // keep reading, so the child never blocks on a full pipe
      char rest[4096];
      while (std::fgets(rest, sizeof rest, log_)) {
        json j = json::parse(rest, nullptr, false);
        std::lock_guard lk(mu_);
        if (!j.is_discarded()) events_.push_back(std::move(j));
      }
    });
  }
  ~Vismapd() {
    if (pid_ > 0) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (drain_.joinable()) drain_.join();
    if (log_) std::fclose(log_);
  }
  const std::string& port() const { return port_; }
  // VmRSS (now) or VmHWM (peak) of the child, in MiB.
  double status_mib(const char* key) const {
    std::ifstream f("/proc/" + std::to_string(pid_) + "/status");
    std::string line;
    while (std::getline(f, line))
      if (line.rfind(key, 0) == 0) return std::stod(line.substr(std::strlen(key))) / 1024;
    return 0;
  }
  double rss_mib() const { return status_mib("VmRSS:"); }
  void signal(int sig) const { ::kill(pid_, sig); }
  // Waits up to timeout_s for the child to exit; returns its exit status, or -1.
  int wait_exit(double timeout_s) {
    auto t0 = std::chrono::steady_clock::now();
    while (std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() <
           timeout_s) {
      int st = 0;
      if (::waitpid(pid_, &st, WNOHANG) == pid_) {
        pid_ = -1;
        return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    return -1;
  }
  // Waits (at most 10 s) until the resident size stops changing: the Renderer is built on the
  // worker after start, and PoCL's setup is a good part of the process's memory.
  double settled_rss_mib() const {
    double last = rss_mib();
    for (int i = 0; i < 50; ++i) {
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
      double now = rss_mib();
      if (std::abs(now - last) < 0.5) return now;
      last = now;
    }
    return last;
  }

 private:
  pid_t pid_ = -1;
  FILE* log_ = nullptr;
  std::string port_;
  std::thread drain_;
  std::mutex mu_;
  std::vector<json> events_;

 public:
  // The log events named `event` so far.
  std::vector<json> events(const std::string& event) {
    std::lock_guard lk(mu_);
    std::vector<json> out;
    for (const json& j : events_)
      if (j.value("event", "") == event) out.push_back(j);
    return out;
  }
};

}  // namespace
