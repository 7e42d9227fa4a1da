// The shared thread pool behind detail::parallel_for.
#include "thread_pool.hpp"

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <deque>
#include <exception>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include <unistd.h>

namespace pairgrasp::detail {

namespace {

// One parallel loop: its items are handed out by an atomic counter to the caller and to any
// worker that joins while it is open.
struct Job {
  const std::function<void(std::size_t)>* body = nullptr;
  std::size_t n = 0;
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  std::condition_variable idle;
  int running = 0;      // workers inside work()
  bool closed = false;  // the caller is done: late workers leave at once
  std::exception_ptr error;

  void work() {
    for (;;) {
      const std::size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= n) return;
      try {
        (*body)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
        next.store(n, std::memory_order_relaxed);
      }
    }
  }
};

class Pool {
 public:
  ~Pool() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stop_ = true;
    }
    wake_.notify_all();
    for (std::thread& t : workers_) t.join();
  }

  void run(std::size_t n, int helpers, const std::function<void(std::size_t)>& body) {
    auto job = std::make_shared<Job>();
    job->body = &body;
    job->n = n;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      while (static_cast<int>(workers_.size()) < std::min(helpers, kMaxWorkers))
        workers_.emplace_back([this] { loop(); });
      for (int k = 0; k < helpers; ++k) queue_.push_back(job);
    }
    if (helpers == 1)
      wake_.notify_one();
    else
      wake_.notify_all();
    job->work();
    std::unique_lock<std::mutex> lock(job->mutex);
    job->closed = true;
    job->idle.wait(lock, [&] { return job->running == 0; });
    if (job->error) std::rethrow_exception(job->error);
  }

 private:
  static constexpr int kMaxWorkers = 256;

  void loop() {
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
      }
      {
        std::lock_guard<std::mutex> lock(job->mutex);
        if (job->closed || job->next.load(std::memory_order_relaxed) >= job->n) continue;
        ++job->running;
      }
      job->work();
      {
        std::lock_guard<std::mutex> lock(job->mutex);
        --job->running;
      }
      job->idle.notify_all();
    }
  }

  std::mutex mutex_;
  std::condition_variable wake_;
  std::deque<std::shared_ptr<Job>> queue_;
  std::vector<std::thread> workers_;
  bool stop_ = false;
};

// The pool of this process. A child made by fork() has none of its parent's threads, so it makes
// its own (the parent's object is left alone: its mutexes may have been held at the fork).
Pool& pool() {
  static Pool* instance = new Pool;
  static pid_t owner = getpid();
  static std::mutex guard;
  std::lock_guard<std::mutex> lock(guard);
  if (getpid() != owner) {
    instance = new Pool;
    owner = getpid();
  }
  return *instance;
}

}  // namespace

int resolve_threads(int requested) {
  if (requested > 0) return requested;
  const unsigned hw = std::thread::hardware_concurrency();
  return hw > 0 ? static_cast<int>(hw) : 1;
}

void parallel_for(std::size_t n, int threads, const std::function<void(std::size_t)>& body) {
  const std::size_t t = std::min<std::size_t>(static_cast<std::size_t>(resolve_threads(threads)), n);
  if (t <= 1) {
    for (std::size_t i = 0; i < n; ++i) body(i);
    return;
  }
  pool().run(n, static_cast<int>(t) - 1, body);
}

void parallel_chunks(std::size_t n, int threads, const std::function<void(std::size_t, std::size_t, int)>& body) {
  const std::size_t t = std::max<std::size_t>(1, static_cast<std::size_t>(threads));
  if (t <= 1 || n < 2) {
    body(0, n, 0);
    return;
  }
  parallel_for(t, static_cast<int>(t), [&](std::size_t k) { body(n * k / t, n * (k + 1) / t, static_cast<int>(k)); });
}

}  // namespace pairgrasp::detail
