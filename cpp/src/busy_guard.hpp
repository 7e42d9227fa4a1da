#pragma once
// BusyGuard: marks an object that serves one caller at a time as in use for one call, and throws
// BusyError when a second thread calls it meanwhile (error.hpp).
#include <pairgrasp/error.hpp>

#include <atomic>
#include <string>

namespace pairgrasp::detail {

class BusyGuard {
 public:
  BusyGuard(std::atomic<bool>& flag, const char* what) : flag_(flag) {
    if (flag_.exchange(true, std::memory_order_acquire))
      throw BusyError(std::string(what) +
                      ": called from a second thread while a call is running; it serves one caller at a time "
                      "(make one per thread, or serialize the calls)");
  }
  ~BusyGuard() { flag_.store(false, std::memory_order_release); }
  BusyGuard(const BusyGuard&) = delete;
  BusyGuard& operator=(const BusyGuard&) = delete;

 private:
  std::atomic<bool>& flag_;
};

}  // namespace pairgrasp::detail
