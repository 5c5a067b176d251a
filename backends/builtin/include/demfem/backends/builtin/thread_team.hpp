// The threads of one built-in DEM simulation (docs/builtin-dem.md, "Threads on a
// shared machine"). One run() per step: the caller is thread 0, the others are kept from step to
// step and sleep between runs; inside a run, barrier() waits for every thread.
//
// Contract
// - run(body) calls body(tid) once on each of size() threads (tid 0 on the caller) and returns when
//   every call has returned. The body must not throw (a throw terminates, as in an OpenMP region):
//   the loops record failures and the caller raises them after run().
// - barrier(): every thread of the run calls it the same number of times; none passes until all
//   have arrived, and memory written before it is visible to every thread after it.
// - Wait policy, for a machine shared with other processes: a waiting thread spins for at most
//   kSpin (10 microseconds), then sleeps in the kernel until woken. A thread that lost its core
//   therefore costs the others one short spin, not its whole time slice, and a waiting thread
//   gives its core to whoever can use it (its own partner first of all).
// - Copying a team makes a new team of the same size (a simulation's copy gets its own threads).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <cstdint>
#include <functional>
#include <memory>
#include <thread>
#include <vector>

#if defined(__x86_64__) || defined(__i386__)
#include <immintrin.h>
#endif

namespace demfem::builtin {

class ThreadTeam {
 public:
  explicit ThreadTeam(int threads) : size_(threads < 1 ? 1 : threads) { start(); }
  ThreadTeam(const ThreadTeam& other) : size_(other.size_) { start(); }
  ThreadTeam& operator=(const ThreadTeam& other) {
    if (this != &other && other.size_ != size_) {
      stop();
      size_ = other.size_;
      start();
    }
    return *this;
  }
  ~ThreadTeam() { stop(); }

  int size() const { return size_; }

  void run(const std::function<void(int)>& body) {
    if (size_ == 1) {
      body(0);
      return;
    }
    body_ = &body;
    generation_.fetch_add(1, std::memory_order_release);
    wake();
    body(0);
    barrier();
  }

  void barrier() {
    if (size_ == 1) return;
    const std::uint32_t phase = phase_.load(std::memory_order_acquire);
    if (arrived_.fetch_add(1, std::memory_order_acq_rel) + 1 == static_cast<std::uint32_t>(size_)) {
      arrived_.store(0, std::memory_order_relaxed);
      phase_.store(phase + 1, std::memory_order_release);
      wake();
      return;
    }
    waitWhile(phase_, phase);
  }

 private:
  static constexpr std::chrono::microseconds kSpin{10};

  static void pause() {
#if defined(__x86_64__) || defined(__i386__)
    _mm_pause();
#else
    std::this_thread::yield();
#endif
  }

  // Spin a little, then sleep until `value` changes (a notifier stores, then calls wake()).
  template <class T>
  void waitWhile(const std::atomic<T>& value, T old) {
    const auto until = std::chrono::steady_clock::now() + kSpin;
    for (int k = 0;; ++k) {
      if (value.load(std::memory_order_acquire) != old) return;
      pause();
      if (k % 16 == 15 && std::chrono::steady_clock::now() > until) break;
    }
    std::unique_lock<std::mutex> lock(mutex_);
    wake_.wait(lock, [&] { return value.load(std::memory_order_acquire) != old; });
  }
  void wake() {
    { std::lock_guard<std::mutex> lock(mutex_); }  // a waiter is either before its check or asleep
    wake_.notify_all();
  }

  void start() {
    stopping_.store(false);
    const std::uint64_t first = generation_.load();
    for (int tid = 1; tid < size_; ++tid)
      workers_.emplace_back([this, tid, first] {
        std::uint64_t seen = first;
        for (;;) {
          waitWhile(generation_, seen);
          seen = generation_.load(std::memory_order_acquire);
          if (stopping_.load(std::memory_order_acquire)) return;
          (*body_)(tid);
          barrier();
        }
      });
  }

  void stop() {
    if (workers_.empty()) return;
    stopping_.store(true, std::memory_order_release);
    generation_.fetch_add(1, std::memory_order_release);
    wake();
    for (auto& w : workers_) w.join();
    workers_.clear();
  }

  int size_;
  std::vector<std::thread> workers_;
  const std::function<void(int)>* body_ = nullptr;
  std::atomic<std::uint64_t> generation_{0};
  std::atomic<bool> stopping_{false};
  std::atomic<std::uint32_t> arrived_{0};
  std::atomic<std::uint32_t> phase_{0};
  std::mutex mutex_;
  std::condition_variable wake_;
};

}  // namespace demfem::builtin
