// dslam::Worker<Job>: the one queue + thread loop (local mapping, loop
// closing, detectors). Start/stop/drain/pause semantics tested once here.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <future>
#include <mutex>
#include <vector>

#include "dslam/core/worker.h"

using dslam::Worker;

namespace {

struct Recorder {
  std::mutex m;
  std::vector<int> seen;
  std::thread::id last_thread;
  void add(int v) {
    std::lock_guard<std::mutex> lk(m);
    seen.push_back(v);
    last_thread = std::this_thread::get_id();
  }
  std::vector<int> get() {
    std::lock_guard<std::mutex> lk(m);
    return seen;
  }
};

}  // namespace

TEST(Worker, WithoutThreadNothingRunsUntilDrain) {
  Recorder r;
  Worker<int> w([&](int& j) { r.add(j); });
  for (int i = 0; i < 5; i++) w.push(i);
  EXPECT_EQ(w.queued(), 5u);
  EXPECT_TRUE(r.get().empty());
  w.drain();
  EXPECT_EQ(r.get(), (std::vector<int>{0, 1, 2, 3, 4}));
  EXPECT_EQ(r.last_thread, std::this_thread::get_id());
  EXPECT_EQ(w.queued(), 0u);
}

TEST(Worker, DrainRunsJobsPushedByTheHandler) {
  Recorder r;
  Worker<int>* self = nullptr;
  Worker<int> w([&](int& j) {
    r.add(j);
    if (j < 3) self->push(j + 1);
  });
  self = &w;
  w.push(0);
  w.drain();
  EXPECT_EQ(r.get(), (std::vector<int>{0, 1, 2, 3}));
}

TEST(Worker, ThreadRunsJobsInOrderAndStopFinishesTheQueue) {
  Recorder r;
  Worker<int> w([&](int& j) {
    std::this_thread::sleep_for(std::chrono::microseconds(200));
    r.add(j);
  });
  w.start();
  EXPECT_TRUE(w.running());
  for (int i = 0; i < 50; i++) w.push(i);
  w.stop();  // must not drop queued jobs
  EXPECT_FALSE(w.running());
  const auto seen = r.get();
  ASSERT_EQ(seen.size(), 50u);
  for (int i = 0; i < 50; i++) EXPECT_EQ(seen[i], i);
  EXPECT_NE(r.last_thread, std::this_thread::get_id());
  // restartable
  w.start();
  w.push(99);
  w.waitIdle();
  EXPECT_EQ(r.get().back(), 99);
}

// start(on_start): the hook runs in the worker's own thread, before its first job.
TEST(Worker, StartHookRunsInTheWorkerThreadBeforeTheJobs) {
  Recorder r;
  std::thread::id hook_thread;
  Worker<int> w([&](int& j) { r.add(j); });
  w.push(1);  // queued before start: still after the hook
  w.start([&] {
    hook_thread = std::this_thread::get_id();
    r.add(0);
  });
  w.push(2);
  w.waitIdle();
  EXPECT_EQ(r.get(), (std::vector<int>{0, 1, 2}));
  EXPECT_EQ(hook_thread, r.last_thread);
  EXPECT_NE(hook_thread, std::this_thread::get_id());
}

TEST(Worker, WaitIdleReturnsOnlyWhenQueueEmptyAndJobDone) {
  std::atomic<int> done{0};
  Worker<int> w([&](int&) {
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
    done++;
  });
  w.start();
  for (int i = 0; i < 20; i++) w.push(i);
  w.waitIdle();
  EXPECT_EQ(done.load(), 20);
  EXPECT_FALSE(w.busy());
  EXPECT_EQ(w.queued(), 0u);
}

// Back-pressure: waitQueuedBelow(n) holds the producer while n or more jobs
// wait, and lets it go as the thread works the queue down.
TEST(Worker, WaitQueuedBelowHoldsTheProducerUntilTheQueueShrinks) {
  std::mutex gate_m;
  std::condition_variable gate_cv;
  int allowed = 0;  // jobs the handler may finish
  std::atomic<int> done{0};
  Worker<int> w([&](int&) {
    std::unique_lock<std::mutex> lk(gate_m);
    gate_cv.wait(lk, [&] { return done.load() < allowed; });
    done++;
  });
  auto allow = [&](int n) {
    {
      std::lock_guard<std::mutex> lk(gate_m);
      allowed = n;
    }
    gate_cv.notify_all();
  };
  w.start();
  for (int i = 0; i < 5; i++) w.push(i);  // one runs (held at the gate), four wait
  auto below2 = std::async(std::launch::async, [&] { w.waitQueuedBelow(2); });
  EXPECT_EQ(below2.wait_for(std::chrono::milliseconds(50)), std::future_status::timeout);
  allow(2);  // two finish, the third runs: two wait
  EXPECT_EQ(below2.wait_for(std::chrono::milliseconds(50)), std::future_status::timeout);
  allow(3);  // one waits
  EXPECT_EQ(below2.wait_for(std::chrono::seconds(10)), std::future_status::ready);
  EXPECT_LE(w.queued(), 1u);
  allow(5);
  w.waitIdle();
  EXPECT_EQ(done.load(), 5);
  // Without a thread it drains in the caller.
  Worker<int> inline_w([&](int&) { done++; });
  inline_w.push(1);
  inline_w.push(2);
  inline_w.waitQueuedBelow(1);
  EXPECT_EQ(done.load(), 7);
}

TEST(Worker, PauseHoldsBetweenJobsAndResumeGoesOn) {
  std::promise<void> entered;
  std::promise<void> release;
  std::shared_future<void> release_f = release.get_future().share();
  std::atomic<int> done{0};
  bool first = true;
  Worker<int> w([&](int&) {
    if (first) {
      first = false;
      entered.set_value();
      release_f.wait();  // the job running when pause() is called completes
    }
    done++;
  });
  w.start();
  w.push(1);
  w.push(2);
  w.push(3);
  entered.get_future().wait();
  auto paused = std::async(std::launch::async, [&] { w.pause(); });
  // pause() cannot return while the first job runs
  EXPECT_EQ(paused.wait_for(std::chrono::milliseconds(50)), std::future_status::timeout);
  release.set_value();
  paused.get();
  EXPECT_TRUE(w.paused());
  EXPECT_EQ(done.load(), 1);  // queued jobs wait while paused
  EXPECT_EQ(w.queued(), 2u);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  EXPECT_EQ(done.load(), 1);
  w.resume();
  w.waitIdle();
  EXPECT_EQ(done.load(), 3);
  EXPECT_FALSE(w.paused());
}

TEST(Worker, StopWhilePausedFinishesTheQueue) {
  std::atomic<int> done{0};
  Worker<int> w([&](int&) { done++; });
  w.start();
  w.pause();
  w.push(1);
  w.push(2);
  w.stop();  // must neither hang nor drop the jobs
  EXPECT_EQ(done.load(), 2);
}

TEST(Worker, PauseAndResumeWithoutThreadAreNoOps) {
  Worker<int> w([](int&) {});
  w.pause();
  EXPECT_FALSE(w.paused());
  w.resume();
  w.push(1);
  w.clear();
  EXPECT_EQ(w.queued(), 0u);
  w.waitIdle();  // drains in the caller: nothing left
}

TEST(Worker, ResultsAndErrorsTravelThroughPromises) {
  struct Job {
    int x = 0;
    std::promise<int> result;
  };
  Worker<Job> w([](Job& j) {
    try {
      if (j.x < 0) throw std::runtime_error("negative");
      j.result.set_value(j.x * 2);
    } catch (...) {
      j.result.set_exception(std::current_exception());
    }
  });
  w.start();
  Job a;
  a.x = 21;
  auto fa = a.result.get_future();
  w.push(std::move(a));
  Job b;
  b.x = -1;
  auto fb = b.result.get_future();
  w.push(std::move(b));
  EXPECT_EQ(fa.get(), 42);
  EXPECT_THROW(fb.get(), std::runtime_error);
}
