#pragma once
/** \file worker.h
 *  dslam::Worker<Job>: one background thread that takes jobs from a FIFO
 *  queue and hands each to a handler. It is the single implementation of the
 *  queue + condition variable + thread loop used by local mapping, loop
 *  closing, the detector threads and the dense map.
 *
 *  Semantics (tested in tests/core/test_worker.cpp):
 *  - push() queues a job and wakes the thread; jobs run in push order, one at
 *    a time, never concurrently with each other.
 *  - Without start() nothing runs in the background: drain() runs every
 *    queued job in the calling thread (sequential mode, deterministic).
 *    start(on_start) runs on_start in the new thread before any job.
 *  - stop() lets the thread finish every queued job (drain semantics), then
 *    joins it; the destructor calls stop(). A stopped worker can be started
 *    again.
 *  - waitIdle() returns once the queue is empty and no job is running (in the
 *    calling thread through drain() when the thread is not running);
 *    waitQueuedBelow(n) once fewer than n jobs are queued.
 *  - pause() returns once the thread is between jobs and holds there (the job
 *    running when pause() is called completes; queued jobs wait); resume()
 *    lets it go on. Both are no-ops without a running thread.
 *  - clear() drops the queued jobs (not the running one).
 *  - A handler must not throw: jobs report errors through their own channel
 *    (e.g. a std::promise); an exception escaping a handler terminates, as
 *    for any std::thread. */
#include <atomic>
#include <condition_variable>
#include <deque>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>

namespace dslam {

template <class Job>
class Worker {
 public:
  using Handler = std::function<void(Job&)>;

  explicit Worker(Handler handler) : handler_(std::move(handler)) {}
  ~Worker() { stop(); }
  Worker(const Worker&) = delete;
  Worker& operator=(const Worker&) = delete;

  /** Starts the background thread (no-op when it runs). `on_start`, if
   *  given, runs first in the new thread (its priority, its name). */
  void start(std::function<void()> on_start = {}) {
    if (thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lk(m_);
      finish_ = false;
      exited_ = false;
      pause_req_ = false;
    }
    thread_ = std::thread([this, on_start = std::move(on_start)] {
      if (on_start) on_start();
      loop();
    });
  }
  bool running() const { return thread_.joinable(); }

  void push(Job job) {
    {
      std::lock_guard<std::mutex> lk(m_);
      queue_.push_back(std::move(job));
    }
    cv_.notify_all();
  }
  size_t queued() const {
    std::lock_guard<std::mutex> lk(m_);
    return queue_.size();
  }
  /** True while the thread runs a job. */
  bool busy() const { return busy_; }
  /** True while the thread holds between jobs after pause(). */
  bool paused() const { return paused_; }

  /** Runs every queued job in the calling thread, including jobs pushed by
   *  the handlers meanwhile. Meant for when the thread is not running. */
  void drain() {
    for (;;) {
      Job job;
      {
        std::lock_guard<std::mutex> lk(m_);
        if (queue_.empty()) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      handler_(job);
    }
  }

  /** Finishes the queued jobs in the thread and joins it. */
  void stop() {
    if (!thread_.joinable()) return;
    {
      std::lock_guard<std::mutex> lk(m_);
      finish_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

  void waitIdle() {
    if (!thread_.joinable()) {
      drain();
      return;
    }
    std::unique_lock<std::mutex> lk(m_);
    cv_.wait(lk, [this] { return (queue_.empty() && !busy_) || exited_; });
  }

  /** Returns once fewer than `n` jobs wait in the queue (the running one
   *  not counted): back-pressure for a producer faster than the thread.
   *  Without a running thread it drains the queue in the calling thread. A
   *  paused worker holds the caller until resume(). */
  void waitQueuedBelow(size_t n) {
    if (!thread_.joinable()) {
      drain();
      return;
    }
    std::unique_lock<std::mutex> lk(m_);
    cv_.wait(lk, [&] { return queue_.size() < n || exited_; });
  }

  void pause() {
    if (!thread_.joinable()) return;
    std::unique_lock<std::mutex> lk(m_);
    pause_req_ = true;
    cv_.notify_all();
    cv_.wait(lk, [this] { return paused_.load() || exited_; });
  }
  void resume() {
    {
      std::lock_guard<std::mutex> lk(m_);
      pause_req_ = false;
    }
    cv_.notify_all();
  }

  void clear() {
    std::lock_guard<std::mutex> lk(m_);
    queue_.clear();
  }

 private:
  void loop() {
    std::unique_lock<std::mutex> lk(m_);
    for (;;) {
      cv_.wait(lk, [this] { return finish_ || pause_req_ || !queue_.empty(); });
      if (pause_req_ && !finish_) {
        paused_ = true;
        cv_.notify_all();
        cv_.wait(lk, [this] { return !pause_req_ || finish_; });
        paused_ = false;
        continue;
      }
      if (queue_.empty()) {
        if (finish_) break;
        continue;
      }
      Job job = std::move(queue_.front());
      queue_.pop_front();
      busy_ = true;
      cv_.notify_all();  // a queue slot is free (waitQueuedBelow)
      lk.unlock();
      handler_(job);
      lk.lock();
      busy_ = false;
      cv_.notify_all();
    }
    exited_ = true;
    cv_.notify_all();
  }

  Handler handler_;
  mutable std::mutex m_;
  std::condition_variable cv_;
  std::deque<Job> queue_;
  std::atomic<bool> busy_{false}, paused_{false};
  bool finish_ = false, pause_req_ = false, exited_ = false;
  std::thread thread_;
};

}  // namespace dslam
