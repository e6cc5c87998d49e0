// The fair render queue: latest task wins per session, and a session with slow frames cannot
// starve the others. Tasks here are scheduler probes (they sleep), not renders: the queue is
// generic over what a task does; the server tests drive it with the real pipeline.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>

#include "core/pipeline.h"
#include "server/render_queue.h"

using namespace vismap::server;
using namespace std::chrono_literals;

TEST(RenderQueue, LatestTaskWinsPerSession) {
  RenderQueue q(1, nullptr);
  uint64_t a = q.add_session();
  std::atomic<bool> release{false};
  std::atomic<int> ran{0}, last{-1};
  uint64_t blocker = q.add_session();
  q.submit(blocker, [&](vismap::Renderer*) {
    while (!release) std::this_thread::sleep_for(1ms);
  });
  std::this_thread::sleep_for(20ms);  // the worker is now busy with the blocker
  int replaced = 0;
  for (int i = 0; i < 100; ++i)
    replaced += q.submit(a, [&, i](vismap::Renderer*) {
      ++ran;
      last = i;
    });
  EXPECT_EQ(replaced, 99);
  EXPECT_EQ(q.pending(), 1u);
  release = true;
  ASSERT_TRUE(q.drain(10));
  EXPECT_EQ(ran, 1);
  EXPECT_EQ(last, 99);
}

TEST(RenderQueue, SlowSessionDoesNotStarveFastOne) {
  RenderQueue q(1, nullptr);
  uint64_t slow = q.add_session(), fast = q.add_session();
  std::atomic<int> slow_runs{0}, fast_runs{0};
  std::atomic<bool> stop{false};
  std::function<void(vismap::Renderer*)> slow_task, fast_task;
  slow_task = [&](vismap::Renderer*) {
    std::this_thread::sleep_for(50ms);
    ++slow_runs;
    if (!stop) q.submit(slow, slow_task);
  };
  fast_task = [&](vismap::Renderer*) {
    std::this_thread::sleep_for(1ms);
    ++fast_runs;
    if (!stop) q.submit(fast, fast_task);
  };
  q.submit(slow, slow_task);
  q.submit(fast, fast_task);
  std::this_thread::sleep_for(600ms);
  stop = true;
  q.drain(5);
  // Round robin alone would give about one fast frame per slow frame; time accounting gives the
  // fast session far more turns while the slow one still progresses.
  EXPECT_GE(slow_runs, 2);
  EXPECT_GT(fast_runs, 5 * slow_runs);
}

TEST(RenderQueue, RemovedSessionDropsPendingTask) {
  RenderQueue q(1, nullptr);
  uint64_t blocker = q.add_session(), s = q.add_session();
  std::atomic<bool> release{false}, ran{false};
  q.submit(blocker, [&](vismap::Renderer*) {
    while (!release) std::this_thread::sleep_for(1ms);
  });
  std::this_thread::sleep_for(20ms);
  q.submit(s, [&](vismap::Renderer*) { ran = true; });
  q.remove_session(s);
  EXPECT_FALSE(q.submit(s, [&](vismap::Renderer*) { ran = true; }));
  release = true;
  ASSERT_TRUE(q.drain(10));
  EXPECT_FALSE(ran);
}

TEST(RenderQueue, FactoryFailureIsReportedNotFatal) {
  RenderQueue q(1, []() -> std::unique_ptr<vismap::Renderer> {
    throw std::runtime_error("no OpenCL platform");
  });
  uint64_t s = q.add_session();
  std::atomic<bool> got_null{false};
  q.submit(s, [&](vismap::Renderer* r) { got_null = r == nullptr; });
  ASSERT_TRUE(q.drain(10));
  EXPECT_TRUE(got_null);
  EXPECT_EQ(q.device_error(), "no OpenCL platform");
}
