#include "compare/bench_report.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <set>

#include "compare/bench_metrics.hpp"

namespace strata::bench {
namespace {

Status Written(std::ofstream& file, const std::string& path) {
  file.close();
  if (!file) {
    return Error{ErrorCode::kInvalidInput, "cannot write '" + path + "': " + std::strerror(errno)};
  }
  return Status::Ok();
}

// CSV field: quoted when it holds a comma, quote or newline.
std::string Field(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (const char c : text) {
    if (c == '"') quoted += '"';
    quoted += c == '\n' ? ' ' : c;
  }
  return quoted + "\"";
}

std::string Number(double v, const char* format = "%.6g") {
  char buf[64];
  std::snprintf(buf, sizeof(buf), format, v);
  return buf;
}

}  // namespace

std::vector<MethodSummary> Summarize(const std::vector<BenchRow>& rows,
                                     const std::vector<const BenchMethod*>& methods) {
  // Queries every method solved.
  std::map<int, int> solved_by;
  for (const BenchRow& row : rows) solved_by[row.query] += row.outcome.success ? 1 : 0;
  std::set<int> common;
  for (const auto& [query, count] : solved_by) {
    if (count == static_cast<int>(methods.size())) common.insert(query);
  }

  std::vector<MethodSummary> summaries;
  for (const BenchMethod* method : methods) {
    MethodSummary s;
    s.method = method->name();
    s.assessment_s = method->assessment_s();
    std::vector<double> time, length, kappa, kappa_xy;
    std::vector<double> c_time, c_length, c_kappa, c_kappa_xy;
    std::map<std::string, int> failures;
    for (const BenchRow& row : rows) {
      if (row.method != s.method) continue;
      const QueryOutcome& o = row.outcome;
      ++s.queries;
      s.verify_violations += std::max(0, o.verify_violations);
      if (o.check) s.check.Add(*o.check);
      if (!o.success) {
        ++failures[o.reason];
        continue;
      }
      ++s.successes;
      time.push_back(o.plan_s);
      length.push_back(o.length_m);
      kappa.push_back(o.kappa_m);
      kappa_xy.push_back(o.kappa_xy_m);
      if (common.count(row.query) > 0) {
        c_time.push_back(o.plan_s);
        c_length.push_back(o.length_m);
        c_kappa.push_back(o.kappa_m);
        c_kappa_xy.push_back(o.kappa_xy_m);
      }
    }
    s.time_median_s = Median(time);
    s.time_p95_s = Quantile(time, 0.95);
    s.length_median_m = Median(length);
    s.kappa_median = Median(kappa);
    s.kappa_xy_median = Median(kappa_xy);
    s.common_queries = static_cast<int>(c_time.size());
    s.common_time_median_s = Median(c_time);
    s.common_length_median_m = Median(c_length);
    s.common_kappa_median = Median(c_kappa);
    s.common_kappa_xy_median = Median(c_kappa_xy);
    for (const auto& [reason, count] : failures) {
      s.failures += (s.failures.empty() ? "" : " ") + reason + " " + std::to_string(count);
    }
    if (s.failures.empty()) s.failures = "none";
    summaries.push_back(s);
  }
  return summaries;
}

std::string SummaryMarkdown(const std::string& map, const std::vector<MethodSummary>& summary) {
  std::string text = "map: " + map + "\n\n";
  text +=
      "| method | success | t_a s | time ms median / p95 | length m median | κ_m 3D 1/m median | "
      "κ_m x–y 1/m median | common queries: length m / κ_m x–y median | failures |\n"
      "|---|---|---|---|---|---|---|---|---|\n";
  for (const MethodSummary& s : summary) {
    const double rate = s.queries > 0 ? 100.0 * s.successes / s.queries : 0;
    text +=
        "| " + s.method + " | " + std::to_string(s.successes) + "/" + std::to_string(s.queries) +
        " (" + Number(rate, "%.1f") + "%) | " + Number(s.assessment_s, "%.3f") + " | " +
        Number(1e3 * s.time_median_s, "%.1f") + " / " + Number(1e3 * s.time_p95_s, "%.1f") + " | " +
        Number(s.length_median_m, "%.2f") + " | " + Number(s.kappa_median, "%.3f") + " | " +
        Number(s.kappa_xy_median, "%.3f") + " | " + std::to_string(s.common_queries) + ": " +
        Number(s.common_length_median_m, "%.2f") + " / " +
        Number(s.common_kappa_xy_median, "%.3f") + " | " + s.failures +
        (s.method == "strata" ? "; verification violations " + std::to_string(s.verify_violations) +
                                    "; independent check of " + s.check.Describe()
                              : "") +
        " |\n";
  }
  return text;
}

Status WriteResultsCsv(const std::string& path, const std::string& map,
                       const std::vector<BenchRow>& rows) {
  std::ofstream file(path);
  file << "map,query,method,start_x,start_y,start_z,goal_x,goal_y,goal_z,success,reason,"
          "plan_s,length_m,kappa_m,kappa_xy_m,verify_violations,start_snap_m,goal_snap_m,"
          "path_points,duration_s,duration_ratio,time_stretch,fallback,iterations,limiting_bound," +
              bench::IndependentCheckCsvHeader() + ",message\n";
  for (const BenchRow& r : rows) {
    const QueryOutcome& o = r.outcome;
    file << Field(map) << ',' << r.query << ',' << r.method;
    for (const Eigen::Vector3d* p : {&r.pair.start_m, &r.pair.goal_m}) {
      for (int a = 0; a < 3; ++a) file << ',' << Number((*p)(a), "%.4f");
    }
    file << ',' << (o.success ? 1 : 0) << ',' << o.reason << ',' << Number(o.plan_s) << ','
         << Number(o.length_m) << ',' << Number(o.kappa_m) << ',' << Number(o.kappa_xy_m) << ','
         << o.verify_violations << ',' << Number(o.start_snap_m, "%.4f") << ','
         << Number(o.goal_snap_m, "%.4f") << ',' << o.points_m.size() << ',' << Number(o.duration_s)
         << ',' << Number(o.duration_ratio) << ',' << Number(o.time_stretch) << ','
         << (o.fallback ? 1 : 0) << ',' << o.iterations << ',' << o.limiting_bound << ','
         << bench::IndependentCheckCsvValues(o.check ? &*o.check : nullptr) << ','
         << Field(o.message) << '\n';
  }
  return Written(file, path);
}

Status WriteSummaryCsv(const std::string& path, const std::string& map,
                       const std::vector<MethodSummary>& summary) {
  std::ofstream file(path);
  file << "map,method,queries,successes,success_rate,t_a_s,time_median_s,time_p95_s,"
          "length_median_m,kappa_median,kappa_xy_median,common_queries,common_time_median_s,"
          "common_length_median_m,common_kappa_median,common_kappa_xy_median,"
          "verify_violations,independent_check,failures\n";
  for (const MethodSummary& s : summary) {
    file << Field(map) << ',' << s.method << ',' << s.queries << ',' << s.successes << ','
         << Number(s.queries > 0 ? double(s.successes) / s.queries : 0) << ','
         << Number(s.assessment_s) << ',' << Number(s.time_median_s) << ',' << Number(s.time_p95_s)
         << ',' << Number(s.length_median_m) << ',' << Number(s.kappa_median) << ','
         << Number(s.kappa_xy_median) << ',' << s.common_queries << ','
         << Number(s.common_time_median_s) << ',' << Number(s.common_length_median_m) << ','
         << Number(s.common_kappa_median) << ',' << Number(s.common_kappa_xy_median) << ','
         << s.verify_violations << ','
         << Field(s.method == "strata" ? s.check.Describe() : std::string()) << ','
         << Field(s.failures) << '\n';
  }
  return Written(file, path);
}

Status WritePathsCsv(const std::string& path, const std::vector<BenchRow>& rows, int max_queries) {
  std::ofstream file(path);
  file << "method,query,index,x,y,z\n";
  for (const BenchRow& r : rows) {
    if (r.query >= max_queries || !r.outcome.success) continue;
    for (std::size_t i = 0; i < r.outcome.points_m.size(); ++i) {
      const Eigen::Vector3d& p = r.outcome.points_m[i];
      file << r.method << ',' << r.query << ',' << i << ',' << Number(p.x(), "%.3f") << ','
           << Number(p.y(), "%.3f") << ',' << Number(p.z(), "%.3f") << '\n';
    }
  }
  return Written(file, path);
}

Status WriteCloudCsv(const std::string& path, const PointCloud& cloud, std::size_t max_points) {
  std::ofstream file(path);
  file << "x,y,z\n";
  const std::size_t stride = std::max<std::size_t>(1, (cloud.size() + max_points - 1) / max_points);
  for (std::size_t i = 0; i < cloud.size(); i += stride) {
    file << Number(cloud[i].x(), "%.3f") << ',' << Number(cloud[i].y(), "%.3f") << ','
         << Number(cloud[i].z(), "%.3f") << '\n';
  }
  return Written(file, path);
}

}  // namespace strata::bench
