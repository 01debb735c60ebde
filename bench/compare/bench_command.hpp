#pragma once
// `strata-bench`: the comparison of paper Table 2. Strata, the Liu-style
// and the Krüsi-style baselines (bench/baselines/) plan the same random start/goal pairs on
// one map; every method's terrain assessment is timed once, every query is measured the same
// way (bench_metrics), and the run is written as CSV files plus a markdown summary.

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

namespace strata::bench {

/// Adds the harness's options to `app` (strata-bench --help lists them). When the line parses,
/// *run becomes the run, which returns the process exit code: 0 the run completed (whatever the
/// success rates), 1 the map could not be loaded or assessed or an output could not be
/// written. `command_line` is recorded in meta.json.
void AddBenchOptions(CLI::App& app, std::vector<std::string> command_line,
                     std::function<int()>* run);

}  // namespace strata::bench
