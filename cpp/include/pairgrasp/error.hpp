#pragma once
/// @file error.hpp
/// The one error policy of pairgrasp.
///
/// - A file that is missing, unreadable or malformed throws pairgrasp::FileError; the message
///   starts with the file's path and names the field or line at fault.
///   (Python: RuntimeError subclass `pairgrasp.FileError`.)
/// - A bad argument value (wrong size, NaN, out-of-range DOF, non-positive length, empty mask)
///   throws std::invalid_argument naming the argument, e.g. "dofs: expected 4 values, got 3".
///   (Python: ValueError.)
/// - A request that cannot be met within a configured resource bound (pair budget) throws
///   pairgrasp::BudgetError, a std::invalid_argument that says what would fit. (Python: ValueError.)
/// - An object that serves one caller at a time (GraspSearch, CandidatePipeline) called from a
///   second thread while a call runs throws pairgrasp::BusyError, a std::logic_error naming the
///   object. (Python: RuntimeError.)
/// No function returns NaN or a silently wrong answer for bad input.
#include <stdexcept>
#include <string>

namespace pairgrasp {

/// A user file could not be read or understood. what() names the file.
class FileError : public std::runtime_error {
 public:
  FileError(const std::string& path, const std::string& message)
      : std::runtime_error(path + ": " + message), path_(path) {}
  /// The file at fault, as given by the caller.
  const std::string& path() const noexcept { return path_; }

 private:
  std::string path_;
};

/// A request exceeds a configured resource budget (e.g. the number of stored target pairs).
class BudgetError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

/// A second thread called an object that serves one caller at a time while a call was running.
class BusyError : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

namespace detail {
/// Throws std::invalid_argument("<what>: expected <expected>, got <got>") when they differ.
inline void check_size(const char* what, long expected, long got) {
  if (expected != got)
    throw std::invalid_argument(std::string(what) + ": expected " + std::to_string(expected) +
                                ", got " + std::to_string(got));
}
}  // namespace detail

}  // namespace pairgrasp
