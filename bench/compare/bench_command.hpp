#pragma once
// `strata-bench`: the comparison of paper Table 2. Strata, the Liu-style
// and the Krüsi-style baselines (bench/baselines/) plan the same random start/goal pairs on
// one map; every method's terrain assessment is timed once, every query is measured the same
// way (bench_metrics), and the run is written as CSV files plus a markdown summary.

#include <string>
#include <vector>

namespace strata::bench {

/// Runs the command on its arguments (after "bench"); returns the process exit code:
/// 0 the run completed (whatever the success rates), 1 the map could not be loaded or
/// assessed or an output could not be written, 2 bad arguments.
int RunBench(const std::vector<std::string>& args);

}  // namespace strata::bench
