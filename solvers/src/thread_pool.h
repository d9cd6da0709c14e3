#pragma once
// Internal: a fixed set of worker threads that run one function split into K parts.
//
// Run(f) calls f(part) once for every part in [0, K): part 0 on the calling thread, the
// others on the workers, and returns when all are done. The workers live as long as the
// pool, so a call creates no thread and allocates nothing (the solver calls it several
// times per iteration). An exception thrown by a part is rethrown by Run on the caller
// (the one of the lowest part when several throw).
//
// Hand-over: the caller and the workers first spin for a few tens of microseconds on atomics
// before they block on a condition variable, so that parallel steps that follow each other
// closely (linearise, then assemble) pay no sleep and wake-up between them; after a long
// serial step (a factorisation) the workers are asleep and cost nothing.
#include <atomic>
#include <condition_variable>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace tether {
namespace internal {

class ThreadPool {
 public:
  /// K = num_threads parts; num_threads <= 1 runs everything on the caller, with no thread.
  explicit ThreadPool(int num_threads);
  ~ThreadPool();
  ThreadPool(const ThreadPool&) = delete;
  ThreadPool& operator=(const ThreadPool&) = delete;

  int num_threads() const { return num_threads_; }

  template <typename F>
  void Run(F& f) {
    RunParts([](void* ctx, int part) { (*static_cast<F*>(ctx))(part); }, &f);
  }

 private:
  using PartFn = void (*)(void* ctx, int part);
  void RunParts(PartFn fn, void* ctx);
  void Work(int part);

  int num_threads_;
  std::vector<std::thread> workers_;
  std::vector<std::exception_ptr> errors_;  // one slot per part
  std::mutex mutex_;
  std::condition_variable start_, done_;
  PartFn fn_ = nullptr;
  void* ctx_ = nullptr;
  std::atomic<unsigned long> generation_{0};  // incremented (under mutex_) for every Run
  std::atomic<int> pending_{0};               // workers still running the current generation
  std::atomic<bool> stop_{false};
};

}  // namespace internal
}  // namespace tether
