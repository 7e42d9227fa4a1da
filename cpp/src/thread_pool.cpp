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
// thread that joins while it is open (a worker, or the caller of another loop waiting for its own).
struct Job {
  const std::function<void(std::size_t)>* body = nullptr;
  std::size_t n = 0;
  std::atomic<std::size_t> next{0};
  std::mutex mutex;
  int running = 0;      // other threads inside work()
  bool closed = false;  // the caller is done: late helpers leave at once
  std::exception_ptr error;

  // Runs items until none is left, or (`one`) a single item; false when there was none to run.
  bool work(bool one = false) {
    bool any = false;
    for (;;) {
      const std::size_t i = next.fetch_add(1, std::memory_order_relaxed);
      if (i >= n) return any;
      any = true;
      try {
        (*body)(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(mutex);
        if (!error) error = std::current_exception();
        next.store(n, std::memory_order_relaxed);
      }
      if (one) return true;
    }
  }
  bool idle() {
    std::lock_guard<std::mutex> lock(mutex);
    return running == 0;
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
    waiting_.notify_all();
    job->work();
    {
      std::lock_guard<std::mutex> lock(job->mutex);
      job->closed = true;
    }
    // Until the threads still inside this loop's items are done, the caller runs items of other
    // open loops (those nested in the items it waits for, typically) one at a time, rather than idle.
    // An item it runs may wait in turn and help again: past kMaxHelping levels it only waits, so that
    // the stack stays bounded.
    const bool help = helping < kMaxHelping;
    for (;;) {
      std::shared_ptr<Job> other;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        waiting_.wait(lock, [&] { return job->idle() || (help && !queue_.empty()); });
        if (job->idle()) break;
        other = queue_.front();
        if (!join(*other)) {
          queue_.pop_front();
          continue;
        }
      }
      ++helping;
      while (!job->idle() && other->work(true)) {
      }
      --helping;
      leave(*other);
    }
    if (job->error) std::rethrow_exception(job->error);
  }

 private:
  static constexpr int kMaxWorkers = 256;
  static constexpr int kMaxHelping = 4;
  static thread_local int helping;  // levels of other loops' items this thread is running while it waits

  void loop() {
    for (;;) {
      std::shared_ptr<Job> job;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        wake_.wait(lock, [&] { return stop_ || !queue_.empty(); });
        if (stop_) return;
        job = std::move(queue_.front());
        queue_.pop_front();
        if (!join(*job)) continue;
      }
      job->work();
      leave(*job);
    }
  }

  // Enters an open job with items left (counted in `running`); false when it is done.
  static bool join(Job& job) {
    std::lock_guard<std::mutex> lock(job.mutex);
    if (job.closed || job.next.load(std::memory_order_relaxed) >= job.n) return false;
    ++job.running;
    return true;
  }
  // Leaves a job entered by join(), and wakes the callers waiting for their jobs (through mutex_,
  // so that none misses it between its test and its wait).
  void leave(Job& job) {
    {
      std::lock_guard<std::mutex> lock(job.mutex);
      --job.running;
    }
    { std::lock_guard<std::mutex> lock(mutex_); }
    waiting_.notify_all();
  }

  std::mutex mutex_;
  std::condition_variable wake_;     // workers: a job was queued, or the pool stops
  std::condition_variable waiting_;  // callers: a job was queued, or a helper left one
  std::deque<std::shared_ptr<Job>> queue_;
  std::vector<std::thread> workers_;
  bool stop_ = false;
};

thread_local int Pool::helping = 0;

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
