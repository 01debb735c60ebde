#pragma once
// Bounds of tests that promise "promptly" (a cancelled assessment stops within a second) hold
// for a Release build; an instrumented build runs the same work many times slower.

namespace strata::test_util {

/// How many times slower than a Release build this test binary runs: 1, 10 under ASan + UBSan,
/// 20 under ThreadSanitizer (set per build in tests/CMakeLists.txt).
inline constexpr int kTimeScale = STRATA_TEST_TIME_SCALE;

}  // namespace strata::test_util
