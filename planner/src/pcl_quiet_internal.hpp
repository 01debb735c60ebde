#pragma once
// PCL reports problems on the console (parse errors, degenerate RANSAC samples); the library
// never prints, and every failure it cares about becomes an Error or a fallback instead.

#include <mutex>

#include <pcl/console/print.h>

namespace strata::internal {

inline void SilencePclConsole() {
  static std::once_flag once;
  std::call_once(once, [] { pcl::console::setVerbosityLevel(pcl::console::L_ALWAYS); });
}

}  // namespace strata::internal
