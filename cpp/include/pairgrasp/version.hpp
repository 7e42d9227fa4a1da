#pragma once
/// @file version.hpp
/// Library version.
namespace pairgrasp {
/// The library version, "MAJOR.MINOR.PATCH".
const char* version();
}  // namespace pairgrasp
