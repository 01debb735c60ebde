#pragma once
// What `strata-bench` writes: one CSV row per method × query, the summary per method
// (CSV and markdown), the paths of the first queries and a thinned copy of the cloud for the
// plots (bench/plots/plot_bench.py reads them).

#include <string>
#include <vector>

#include "compare/bench_methods.hpp"
#include "strata/point_cloud.hpp"
#include "strata/status.hpp"

namespace strata::bench {

struct BenchRow {
  int query = 0;       ///< Index of the pair, from 0.
  std::string method;  ///< strata, liu or krusi.
  QueryPair pair;
  QueryOutcome outcome;
};

/// Per-method figures over all rows of a run.
struct MethodSummary {
  std::string method;
  int queries = 0, successes = 0;
  double assessment_s = 0;                                            ///< t_a [s].
  double time_median_s = 0, time_p95_s = 0;                           ///< Over successful queries.
  double length_median_m = 0, kappa_median = 0, kappa_xy_median = 0;  ///< Successes.
  /// The same medians over the queries every method of the run solved (like for like).
  int common_queries = 0;
  double common_time_median_s = 0, common_length_median_m = 0, common_kappa_median = 0,
         common_kappa_xy_median = 0;
  int verify_violations = 0;           ///< Strata: returned plans that failed re-verification.
  bench::IndependentCheckTally check;  ///< Strata: the harness's own check of its plans.
  std::string failures;                ///< "REASON count" pairs, or "none".
};

/// One summary per method in `methods` order.
std::vector<MethodSummary> Summarize(const std::vector<BenchRow>& rows,
                                     const std::vector<const BenchMethod*>& methods);

/// The summary as a markdown table (times in ms).
std::string SummaryMarkdown(const std::string& map, const std::vector<MethodSummary>& summary);

/// Writers; each fails with kInvalidInput naming the file when it cannot be written.
Status WriteResultsCsv(const std::string& path, const std::string& map,
                       const std::vector<BenchRow>& rows);
Status WriteSummaryCsv(const std::string& path, const std::string& map,
                       const std::vector<MethodSummary>& summary);
/// Points of the successful rows of queries < max_queries: method,query,index,x,y,z.
Status WritePathsCsv(const std::string& path, const std::vector<BenchRow>& rows, int max_queries);
/// Up to max_points points of the cloud (every k-th): x,y,z.
Status WriteCloudCsv(const std::string& path, const PointCloud& cloud, std::size_t max_points);

}  // namespace strata::bench
