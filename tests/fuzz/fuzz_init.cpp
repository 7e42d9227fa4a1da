// libFuzzer start-up of every harness: an exception that escapes a target (outside the parsers'
// own handlers, for example from the scratch folder's file operations) ends the process through
// std::terminate; this handler names the exception before the abort, so the crash report says
// what was thrown instead of only "deadly signal".
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <typeinfo>

namespace {

[[noreturn]] void report_and_abort() {
  if (const std::exception_ptr e = std::current_exception()) {
    try {
      std::rethrow_exception(e);
    } catch (const std::exception& x) {
      std::fprintf(stderr, "pairgrasp fuzz harness: uncaught %s: %s\n", typeid(x).name(), x.what());
    } catch (...) {
      std::fprintf(stderr, "pairgrasp fuzz harness: uncaught exception of a non-standard type\n");
    }
  } else {
    std::fprintf(stderr, "pairgrasp fuzz harness: std::terminate called with no exception\n");
  }
  std::fflush(stderr);
  std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int* /*argc*/, char*** /*argv*/) {
  std::set_terminate(report_and_abort);
  return 0;
}
