// strata-bench: Strata against the Liu-style and Krüsi-style baselines (paper Table 2).

#include <string>
#include <vector>

#include "compare/bench_command.hpp"

int main(int argc, char** argv) {
  return strata::bench::RunBench(std::vector<std::string>(argv + 1, argv + argc));
}
