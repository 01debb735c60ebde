#pragma once
// Order statistics shared by the benchmark binaries and strata-bench.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <vector>

namespace strata::bench {

/// The q-quantile of `values` by nearest rank (the ⌈q·n⌉-th smallest), 0 when empty.
inline double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const auto rank = static_cast<std::size_t>(std::ceil(q * values.size()));
  return values[std::clamp<std::size_t>(rank, 1, values.size()) - 1];
}

/// Quantile(values, 0.5).
inline double Median(std::vector<double> values) { return Quantile(std::move(values), 0.5); }

}  // namespace strata::bench
