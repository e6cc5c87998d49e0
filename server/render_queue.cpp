#include "server/render_queue.h"

#include <chrono>
#include <exception>

#include "core/pipeline.h"

namespace vismap::server {

RenderQueue::RenderQueue(uint32_t workers, RendererFactory make) : make_(std::move(make)) {
  for (uint32_t i = 0; i < std::max<uint32_t>(workers, 1); ++i)
    workers_.emplace_back([this, i] { work(i); });
}

RenderQueue::~RenderQueue() {
  stop();
}

uint64_t RenderQueue::add_session() {
  std::lock_guard lk(mu_);
  uint64_t id = next_session_++;
  sessions_[id].vtime_ms = clock_ms_;
  return id;
}

void RenderQueue::remove_session(uint64_t session) {
  Task dropped;  // destroyed after the lock: it may hold the last reference to its session
  std::lock_guard lk(mu_);
  auto it = sessions_.find(session);
  if (it == sessions_.end()) return;
  if (it->second.task) --pending_;
  dropped = std::move(it->second.task);
  sessions_.erase(it);
  if (pending_ == 0 && running_ == 0) idle_cv_.notify_all();
}

bool RenderQueue::submit(uint64_t session, Task task) {
  Task old;  // destroyed after the lock (see remove_session)
  std::lock_guard lk(mu_);
  auto it = sessions_.find(session);
  if (it == sessions_.end() || stopping_) return false;
  Slot& s = it->second;
  bool replaced = static_cast<bool>(s.task);
  if (!replaced) {
    ++pending_;
    s.order = next_order_++;
    s.vtime_ms = std::max(s.vtime_ms, clock_ms_);  // no credit for idle time
  }
  old = std::move(s.task);
  s.task = std::move(task);
  cv_.notify_one();
  return replaced;
}

// Renderers are built one at a time, process-wide (every RenderQueue, every Server in the
// process). Built concurrently, the OpenCL ICD loader (ocl-icd 2.3.1, Debian 12) initialises
// itself lazily and without a lock on the first clGetPlatformIDs: a second thread that comes
// in meanwhile sees zero platforms ("no OpenCL device found": with --renderers 2 every other
// frame failed), and two threads running PoCL's device initialisation at once segfaulted at
// start with --renderers 3 or 8. Once built, Renderers render concurrently without trouble.
static std::mutex& renderer_build_mutex() {
  static std::mutex mu;
  return mu;
}

void RenderQueue::work(uint32_t index) {
  std::unique_ptr<Renderer> renderer;
  try {
    std::lock_guard build(renderer_build_mutex());
    renderer = make_ ? make_() : nullptr;
  } catch (const std::exception& e) {
    std::lock_guard lk(mu_);
    device_error_ = e.what();
  }
  for (;;) {
    Task task;
    uint64_t session = 0;
    {
      std::unique_lock lk(mu_);
      cv_.wait(lk, [&] { return stopping_ || pending_ > 0; });
      if (stopping_) return;
      Slot* best = nullptr;
      for (auto& [id, s] : sessions_) {
        if (!s.task) continue;
        if (!best || s.vtime_ms < best->vtime_ms ||
            (s.vtime_ms == best->vtime_ms && s.order < best->order)) {
          best = &s;
          session = id;
        }
      }
      task = std::move(best->task);
      best->task = nullptr;
      clock_ms_ = std::max(clock_ms_, best->vtime_ms);
      --pending_;
      ++running_;
    }
    auto t0 = std::chrono::steady_clock::now();
    try {
      task(renderer.get());
    } catch (...) {
      // A task reports its own errors; nothing a session does may take a worker down.
    }
    double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    std::lock_guard lk(mu_);
    auto it = sessions_.find(session);
    if (it != sessions_.end()) it->second.vtime_ms += ms;
    --running_;
    if (pending_ == 0 && running_ == 0) idle_cv_.notify_all();
  }
}

bool RenderQueue::drain(double timeout_s) {
  std::unique_lock lk(mu_);
  return idle_cv_.wait_for(lk, std::chrono::duration<double>(timeout_s),
                           [&] { return pending_ == 0 && running_ == 0; });
}

void RenderQueue::stop() {
  {
    std::lock_guard lk(mu_);
    if (stopping_ && workers_.empty()) return;
    stopping_ = true;
  }
  cv_.notify_all();
  for (auto& t : workers_)
    if (t.joinable()) t.join();
  workers_.clear();
}

std::string RenderQueue::device_error() const {
  std::lock_guard lk(mu_);
  return device_error_;
}

size_t RenderQueue::pending() const {
  std::lock_guard lk(mu_);
  return pending_;
}

double RenderQueue::session_render_ms(uint64_t session) const {
  std::lock_guard lk(mu_);
  auto it = sessions_.find(session);
  return it == sessions_.end() ? 0 : it->second.vtime_ms;
}

}  // namespace vismap::server
