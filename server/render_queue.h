// The render queue: sessions share the device through a few Renderer instances (one worker
// thread each; a Renderer is not thread-safe). Fair between sessions:
//  - each session holds at most ONE pending task; a new submit replaces it (latest camera wins),
//    so nothing queues without bound;
//  - the next task is the pending one whose session has used the least render time so far
//    (virtual time, as in fair queuing / CFS): a session whose frames take 500 ms runs one frame
//    while a 5 ms session runs about a hundred. A session that was idle re-enters at the current
//    virtual clock, so idleness earns no burst credit.
#pragma once

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace vismap {
class Renderer;
}

namespace vismap::server {

class RenderQueue {
 public:
  // The task runs on a worker thread with that worker's Renderer, or nullptr when the Renderer
  // could not be created (the task then reports device_error()).
  using Task = std::function<void(Renderer*)>;
  using RendererFactory = std::function<std::unique_ptr<Renderer>()>;

  RenderQueue(uint32_t workers, RendererFactory make);
  ~RenderQueue();
  RenderQueue(const RenderQueue&) = delete;
  RenderQueue& operator=(const RenderQueue&) = delete;

  uint64_t add_session();
  // Drops the session's pending task; a task already running completes.
  void remove_session(uint64_t session);
  // Returns true when a pending task of this session was replaced (that frame is skipped).
  bool submit(uint64_t session, Task task);
  // Waits until nothing is pending or running, or the timeout passes. Returns true when idle.
  bool drain(double timeout_s);
  // Stops the workers after their running tasks; pending tasks are dropped.
  void stop();

  std::string device_error() const;
  size_t pending() const;
  double session_render_ms(uint64_t session) const;

 private:
  struct Slot {
    Task task;            // empty: nothing pending
    double vtime_ms = 0;  // render time used
    uint64_t order = 0;   // submission order, breaks ties
  };
  void work(uint32_t index);

  RendererFactory make_;
  mutable std::mutex mu_;
  std::condition_variable cv_, idle_cv_;
  std::map<uint64_t, Slot> sessions_;
  uint64_t next_session_ = 1, next_order_ = 1;
  double clock_ms_ = 0;  // virtual time of the last task started
  size_t pending_ = 0, running_ = 0;
  bool stopping_ = false;
  std::string device_error_;
  std::vector<std::thread> workers_;
};

}  // namespace vismap::server
