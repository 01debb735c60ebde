// strata-bench: Strata against the Liu-style and Krüsi-style baselines (paper Table 2).

#include <functional>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "compare/bench_command.hpp"
#include "offline/command_line.hpp"

int main(int argc, char** argv) {
  CLI::App app(
      "strata-bench: Strata, the Liu-style and the Krusi-style baselines (bench/baselines/) plan "
      "the same random start/goal pairs of one map (paper Table 2): terrain assessment time "
      "t_a, per-query time, success, length and mean curvature.",
      "strata-bench");
  app.footer(
      "Exit codes: 0 the run completed (whatever the success rates); 1 the map could not be "
      "loaded or assessed or an output could not be written; 2 bad arguments.\n");
  app.set_help_flag("-h,--help", "print this help and exit");
  std::function<int()> run;
  strata::bench::AddBenchOptions(app, std::vector<std::string>(argv, argv + argc), &run);
  if (const auto exit_code = strata::offline::ParseCommandLine(app, argc, argv)) return *exit_code;
  return run();
}
