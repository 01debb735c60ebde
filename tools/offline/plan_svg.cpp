#include "offline/plan_svg.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <sstream>
#include <utility>
#include <vector>

#include "strata/planning/trajectory_costs.hpp"

namespace strata::offline {
namespace {

// Layout [SVG px]. The top view keeps metres square; the side view stretches height.
constexpr double kMarginLeft = 70;
constexpr double kPlotWidth = 760;         // Width of the side view; most the top view gets.
constexpr double kTopViewMaxHeight = 760;  // Most the top view gets.
constexpr double kLegendGap = 30;          // Between a plot and its legend.
constexpr double kLegendWidth = 170;
constexpr double kTitleHeight = 84;
constexpr double kPanelGap = 80;  // Room for the top view's axis labels and the side caption.
constexpr double kSideViewHeight = 240;
constexpr double kMarginBottom = 50;
constexpr double kLegendBarHeight = 120;
constexpr double kTopLegendHeight = 400;  // The top view is never shorter than its legends.

constexpr int kHeightBands = 24;          // Grey levels of the ground; one <path> each.
constexpr int kSpeedBins = 20;            // Colours of the trajectory.
constexpr double kSampleSpacingM = 0.05;  // Aimed-for arc length between drawn samples.
constexpr int kMinSamples = 200;
constexpr int kMaxSamples = 4000;
// Ceilings further than this above the highest body top are left out of the side view: they
// do not constrain the robot, and the open sky of outdoor maps would flatten the drawing.
constexpr double kCeilingShownAboveBodyM = 2.5;
// Clearance cap for SampleGround, far above the drawn range: next to open sky the interpolated
// clearance then leaves that range within a sliver of a cell instead of dipping into it.
constexpr double kClearanceSampleCapM = 100;

constexpr const char* kGroundFill = "#dccaa0";
constexpr const char* kGroundStroke = "#8a7650";
constexpr const char* kCeilingFill = "#b8b8b8";
constexpr const char* kCeilingStroke = "#555555";
constexpr const char* kBodyStroke = "#1f4fd0";

// printf into a string: libstdc++ 12 has no std::format.
[[gnu::format(printf, 1, 2)]] std::string Fmt(const char* format, ...) {
  va_list args;
  va_start(args, format);
  va_list measure;
  va_copy(measure, args);
  const int length = std::vsnprintf(nullptr, 0, format, measure);
  va_end(measure);
  std::string out(static_cast<std::size_t>(std::max(length, 0)), '\0');
  std::vsnprintf(out.data(), out.size() + 1, format, args);
  va_end(args);
  return out;
}

std::string EscapeXml(const std::string& text) {
  std::string out;
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

struct Rgb {
  double r, g, b;  // Each in [0, 1].
};

std::string Hex(const Rgb& c) {
  const auto byte = [](double v) {
    return static_cast<int>(std::lround(std::clamp(v, 0.0, 1.0) * 255));
  };
  return Fmt("#%02x%02x%02x", byte(c.r), byte(c.g), byte(c.b));
}

// Slow to fast: blue, teal, green, orange, red. Saturated, so it stands out on the grey ground.
Rgb SpeedColor(double fraction) {
  static constexpr std::array<Rgb, 5> kStops = {{{0.12, 0.31, 0.82},
                                                 {0.04, 0.65, 0.65},
                                                 {0.24, 0.69, 0.26},
                                                 {0.95, 0.61, 0.07},
                                                 {0.84, 0.10, 0.11}}};
  const double f = std::clamp(fraction, 0.0, 1.0) * (kStops.size() - 1);
  const std::size_t i = std::min(static_cast<std::size_t>(f), kStops.size() - 2);
  const double t = f - static_cast<double>(i);
  const Rgb& a = kStops[i];
  const Rgb& b = kStops[i + 1];
  return {a.r + t * (b.r - a.r), a.g + t * (b.g - a.g), a.b + t * (b.b - a.b)};
}

// Low ground dark, high ground light, so an upper deck reads as above the floor beneath it.
Rgb GroundGrey(double fraction) {
  const double v = 0.45 + 0.45 * std::clamp(fraction, 0.0, 1.0);
  return {v, v, v};
}

int Bin(double value, double lo, double hi, int bins) {
  if (!(hi - lo > 1e-9)) return 0;
  return std::clamp(static_cast<int>(std::floor((value - lo) / (hi - lo) * bins)), 0, bins - 1);
}

// A tick step of 1, 2 or 5 times a power of ten giving about `target` ticks over `range` > 0.
double NiceStep(double range, int target) {
  const double raw = range / target;
  const double power = std::pow(10.0, std::floor(std::log10(raw)));
  for (const double m : {1.0, 2.0, 5.0}) {
    if (m * power >= raw) return m * power;
  }
  return 10 * power;
}

// The multiples of `step` in [lo, hi].
std::vector<double> Ticks(double lo, double hi, double step) {
  std::vector<double> ticks;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; ++k) {
    ticks.push_back(k * step + 0.0);  // + 0.0 turns -0 into 0 for the labels.
  }
  return ticks;
}

// Maps a panel's coordinates [m] to SVG pixels (SVG y grows downwards).
struct Frame {
  double left_px, top_px, width_px, height_px;
  double x_min, x_max, y_min, y_max;
  double X(double x) const { return left_px + (x - x_min) / (x_max - x_min) * width_px; }
  double Y(double y) const { return top_px + (y_max - y) / (y_max - y_min) * height_px; }
  double right_px() const { return left_px + width_px; }
  double bottom_px() const { return top_px + height_px; }
};

// One drawn point of the trajectory and what lies under and above it.
struct Sample {
  Eigen::Vector3d position_m;  // Reference point.
  double speed_mps;            // ‖v‖ over x, y, z.
  double arc_m;                // Arc length from the start.
  double ground_m;             // Smoothed ground height under the reference point.
  double body_top_m;           // Where the top of the body is.
  double ceiling_m;            // Ground + ceiling clearance; NaN where not drawn.
  bool beneath_upper_level;    // Traversable ground above it hides it in the top view.
};

// Whether a traversable level lies above the robot standing at `ground_m` under `p`. Levels of
// one column are at least the body height apart, so half of it separates "this level" from
// "above" whatever the slope.
bool BeneathUpperLevel(const SurfaceGraph& graph, const Eigen::Vector3d& p, double ground_m) {
  const Eigen::Vector3i cell = graph.grid().CellOf(p);
  const double above = ground_m + 0.5 * graph.params().body_height_m;
  for (const std::int32_t n : graph.ColumnNodes(cell.x(), cell.y())) {
    if (graph.ground_z(n) > above) return true;
  }
  return false;
}

std::vector<Sample> SampleTrajectory(const SurfaceGraph& graph, const PlanResult& plan,
                                     const RobotProfile& profile) {
  const Trajectory& trajectory = plan.trajectory;
  const int count = std::clamp(static_cast<int>(std::ceil(plan.stats.length_m / kSampleSpacingM)),
                               kMinSamples, kMaxSamples);
  const double duration = trajectory.TotalDuration();
  const double highest_body =
      profile.active_height ? profile.body_height_max_m : profile.body_height_m;
  const double shown_clearance = highest_body + profile.headroom_m + kCeilingShownAboveBodyM;
  std::vector<Sample> samples;
  samples.reserve(static_cast<std::size_t>(count) + 1);
  TrajectoryCursor cursor(trajectory);
  for (int i = 0; i <= count; ++i) {
    const double t = duration * i / count;
    const Eigen::VectorXd p = cursor.Position(t);
    Sample s;
    s.position_m = p.head<3>();
    s.speed_mps = cursor.Velocity(t).head<3>().norm();
    s.arc_m = samples.empty()
                  ? 0.0
                  : samples.back().arc_m + (s.position_m - samples.back().position_m).norm();
    GroundSample ground;
    const bool found = SampleGround(graph.model(), s.position_m, profile.reference_height_m,
                                    kClearanceSampleCapM, &ground);
    // The body rides on the robot, so its top follows the reference point, not the sampled
    // ground; the two differ by the plan's ground offset.
    const double standing_on = s.position_m.z() - profile.reference_height_m;
    s.body_top_m = standing_on + (trajectory.dimension == 4 ? p(3) : profile.body_height_m);
    s.ground_m = found ? ground.height_m : standing_on;
    s.ceiling_m = found && ground.clearance_m < shown_clearance
                      ? ground.height_m + ground.clearance_m
                      : std::numeric_limits<double>::quiet_NaN();
    s.beneath_upper_level = BeneathUpperLevel(graph, s.position_m, standing_on);
    samples.push_back(s);
  }
  return samples;
}

// "x,y x,y ..." of points first..last (inclusive), `xy(i)` giving point i in pixels.
template <typename XY>
std::string Points(std::size_t first, std::size_t last, XY xy) {
  std::string out;
  for (std::size_t i = first; i <= last; ++i) {
    const auto [x, y] = xy(i);
    out += Fmt("%.1f,%.1f ", x, y);
  }
  if (!out.empty()) out.pop_back();
  return out;
}

void DrawText(std::ostringstream& out, double x, double y, const std::string& text,
              const char* anchor = "start", const char* extra = "") {
  out << Fmt("<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"%s\"%s>", x, y, anchor, extra)
      << EscapeXml(text) << "</text>\n";
}

std::string TickLabel(double v) { return Fmt("%g", v); }

void DrawAxes(std::ostringstream& out, const Frame& f, const std::string& x_label,
              const std::string& y_label, int x_ticks, int y_ticks) {
  out << Fmt(
      "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"none\" "
      "stroke=\"#444\"/>\n",
      f.left_px, f.top_px, f.width_px, f.height_px);
  out << "<g stroke=\"#444\">\n";
  const std::vector<double> xs = Ticks(f.x_min, f.x_max, NiceStep(f.x_max - f.x_min, x_ticks));
  const std::vector<double> ys = Ticks(f.y_min, f.y_max, NiceStep(f.y_max - f.y_min, y_ticks));
  for (const double x : xs) {
    out << Fmt("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\"/>\n", f.X(x), f.bottom_px(),
               f.X(x), f.bottom_px() + 5);
  }
  for (const double y : ys) {
    out << Fmt("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\"/>\n", f.left_px - 5, f.Y(y),
               f.left_px, f.Y(y));
  }
  out << "</g>\n";
  for (const double x : xs) DrawText(out, f.X(x), f.bottom_px() + 18, TickLabel(x), "middle");
  for (const double y : ys) DrawText(out, f.left_px - 8, f.Y(y) + 4, TickLabel(y), "end");
  DrawText(out, 0.5 * (f.left_px + f.right_px()), f.bottom_px() + 36, x_label, "middle");
  const double y_mid = 0.5 * (f.top_px + f.bottom_px());
  out << Fmt("<text transform=\"translate(%.1f %.1f) rotate(-90)\" text-anchor=\"middle\">",
             f.left_px - 44, y_mid)
      << EscapeXml(y_label) << "</text>\n";
}

struct HeightRange {
  double lo, hi;
};

HeightRange GroundHeights(const SurfaceGraph& graph) {
  HeightRange range{std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest()};
  for (int n = 0; n < graph.node_count(); ++n) {
    range.lo = std::min(range.lo, graph.ground_z(n));
    range.hi = std::max(range.hi, graph.ground_z(n));
  }
  return range;
}

// The traversable columns as grey squares, one shade per height band. Bands are drawn low to
// high, so upper levels cover what lies beneath them; each band is one path of row runs, which
// keeps the file small on large maps.
void DrawGround(std::ostringstream& out, const Frame& f, const SurfaceGraph& graph,
                const HeightRange& heights) {
  std::vector<std::vector<std::pair<int, int>>> bands(kHeightBands);  // (iy, ix) per band.
  for (int n = 0; n < graph.node_count(); ++n) {
    const Eigen::Vector2i c = graph.column(n);
    bands[Bin(graph.ground_z(n), heights.lo, heights.hi, kHeightBands)].emplace_back(c.y(), c.x());
  }
  const GridGeometry& g = graph.grid();
  const double r = g.resolution_m;
  out << "<g shape-rendering=\"crispEdges\">\n";
  for (int b = 0; b < kHeightBands; ++b) {
    std::vector<std::pair<int, int>>& cells = bands[b];
    if (cells.empty()) continue;
    std::sort(cells.begin(), cells.end());
    cells.erase(std::unique(cells.begin(), cells.end()), cells.end());
    out << "<path fill=\"" << Hex(GroundGrey((b + 0.5) / kHeightBands)) << "\" d=\"";
    for (std::size_t i = 0; i < cells.size();) {
      std::size_t j = i + 1;
      while (j < cells.size() && cells[j].first == cells[i].first &&
             cells[j].second == cells[j - 1].second + 1) {
        ++j;
      }
      const double x0 = g.origin_m.x() + cells[i].second * r;
      const double x1 = g.origin_m.x() + (cells[j - 1].second + 1) * r;
      const double y0 = g.origin_m.y() + cells[i].first * r;
      out << Fmt("M%.1f %.1fH%.1fV%.1fH%.1fz", f.X(x0), f.Y(y0 + r), f.X(x1), f.Y(y0), f.X(x0));
      i = j;
    }
    out << "\"/>\n";
  }
  out << "</g>\n";
}

void DrawSearchPath(std::ostringstream& out, const Frame& f, const PathResult& path) {
  if (path.points_m.empty()) return;
  out << "<polyline fill=\"none\" stroke=\"#222\" stroke-width=\"1\" stroke-dasharray=\"5 3\" "
         "points=\""
      << Points(0, path.points_m.size() - 1,
                [&](std::size_t i) {
                  return std::pair{f.X(path.points_m[i].x()), f.Y(path.points_m[i].y())};
                })
      << "\"/>\n";
}

// Consecutive trajectory segments drawn alike: one speed colour, seen or hidden.
struct Run {
  std::size_t first, last;  // Sample indices, inclusive.
  int speed_bin;
  bool hidden;  // Beneath an upper level.
};

std::vector<Run> SplitIntoRuns(const std::vector<Sample>& samples, double speed_scale) {
  const auto style = [&](std::size_t i) {  // Of the segment from sample i to i + 1.
    const double speed = 0.5 * (samples[i].speed_mps + samples[i + 1].speed_mps);
    return std::pair{Bin(speed, 0, speed_scale, kSpeedBins),
                     samples[i].beneath_upper_level && samples[i + 1].beneath_upper_level};
  };
  std::vector<Run> runs;
  for (std::size_t first = 0; first + 1 < samples.size();) {
    const auto [bin, hidden] = style(first);
    std::size_t last = first + 1;
    while (last + 1 < samples.size() && style(last) == std::pair{bin, hidden}) ++last;
    runs.push_back({first, last, bin, hidden});
    first = last;
  }
  return runs;
}

// Seen runs: a speed colour over a white casing that keeps the line legible on every grey.
// Hidden runs (beneath an upper level, which covers their ground): dashed, without casing.
// Casings go first, so no casing covers the end of a neighbouring run.
void DrawTrajectoryTop(std::ostringstream& out, const Frame& f, const std::vector<Sample>& samples,
                       double speed_scale) {
  const auto xy = [&](std::size_t i) {
    return std::pair{f.X(samples[i].position_m.x()), f.Y(samples[i].position_m.y())};
  };
  const std::vector<Run> runs = SplitIntoRuns(samples, speed_scale);
  out << "<g fill=\"none\" stroke-linejoin=\"round\" stroke-linecap=\"round\">\n";
  for (const Run& run : runs) {
    if (run.hidden) continue;
    out << "<polyline stroke=\"white\" stroke-width=\"6\" points=\""
        << Points(run.first, run.last, xy) << "\"/>\n";
  }
  double dashed_px = 0;  // Dashed length so far: each run continues the previous one's dashes.
  for (const Run& run : runs) {
    out << "<polyline stroke=\"" << Hex(SpeedColor((run.speed_bin + 0.5) / kSpeedBins))
        << "\" stroke-width=\"3\"";
    if (run.hidden) {
      out << Fmt(" stroke-dasharray=\"2 6\" stroke-dashoffset=\"%.1f\"", dashed_px);
      for (std::size_t i = run.first; i < run.last; ++i) {
        const auto [x0, y0] = xy(i);
        const auto [x1, y1] = xy(i + 1);
        dashed_px += std::hypot(x1 - x0, y1 - y0);
      }
    }
    out << " points=\"" << Points(run.first, run.last, xy) << "\"/>\n";
  }
  out << "</g>\n";
}

// Start: open circle; goal: filled circle; each at the trajectory's end (the robot's own x, y
// when it lies in the snapped column) and labelled with the level it snapped to.
void DrawEndpoint(std::ostringstream& out, const Frame& f, const Sample& end, int level,
                  const char* name, bool filled) {
  const double x = f.X(end.position_m.x());
  const double y = f.Y(end.position_m.y());
  out << Fmt(
      "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"6\" fill=\"%s\" stroke=\"black\" "
      "stroke-width=\"2\"/>\n",
      x, y, filled ? "black" : "white");
  DrawText(out, x + 10, y - 8, Fmt("%s (level %d)", name, level), "start",
           " font-weight=\"bold\" stroke=\"white\" stroke-width=\"3\" paint-order=\"stroke\"");
}

// A vertical colour bar from `lo` (bottom) to `hi` (top) with ticks, under a title.
template <typename ColorOf>
void DrawColorBar(std::ostringstream& out, double left, double top, const std::string& title,
                  double lo, double hi, int steps, ColorOf color_of) {
  DrawText(out, left, top, title, "start", " font-weight=\"bold\"");
  const double bar_top = top + 14;
  const double step_px = kLegendBarHeight / steps;
  out << "<g shape-rendering=\"crispEdges\">\n";
  for (int i = 0; i < steps; ++i) {
    out << Fmt("<rect x=\"%.1f\" y=\"%.1f\" width=\"16\" height=\"%.1f\" fill=\"%s\"/>\n", left,
               bar_top + kLegendBarHeight - (i + 1) * step_px, step_px + 0.5,
               Hex(color_of((i + 0.5) / steps)).c_str());
  }
  out << "</g>\n";
  out << Fmt(
      "<rect x=\"%.1f\" y=\"%.1f\" width=\"16\" height=\"%.1f\" fill=\"none\" "
      "stroke=\"#444\"/>\n",
      left, bar_top, kLegendBarHeight);
  if (!(hi - lo > 1e-9)) {  // One value: a flat map.
    DrawText(out, left + 22, bar_top + kLegendBarHeight + 4, TickLabel(lo));
    return;
  }
  for (const double v : Ticks(lo, hi, NiceStep(hi - lo, 5))) {
    const double y = bar_top + (hi - v) / (hi - lo) * kLegendBarHeight;
    out << Fmt("<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#444\"/>\n",
               left + 16, y, left + 20, y);
    DrawText(out, left + 24, y + 4, TickLabel(v));
  }
}

void DrawTopLegend(std::ostringstream& out, double left, double top, double speed_scale,
                   const HeightRange& heights) {
  DrawColorBar(out, left, top, "speed ‖v‖ [m/s]", 0, speed_scale, kSpeedBins, SpeedColor);
  const double ground_top = top + kLegendBarHeight + 50;
  DrawColorBar(out, left, ground_top, "ground height [m]", heights.lo, heights.hi, kHeightBands,
               GroundGrey);
  double y = ground_top + kLegendBarHeight + 50;
  out << Fmt(
      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#222\" "
      "stroke-dasharray=\"5 3\"/>\n",
      left, y - 4, left + 24, y - 4);
  DrawText(out, left + 32, y, "A* path");
  y += 20;
  out << Fmt(
      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
      "stroke-width=\"3\"/>\n",
      left, y - 4, left + 24, y - 4, Hex(SpeedColor(0.5)).c_str());
  DrawText(out, left + 32, y, "trajectory (speed)");
  y += 20;
  out << Fmt(
      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
      "stroke-width=\"3\" stroke-linecap=\"round\" stroke-dasharray=\"2 6\"/>\n",
      left + 2, y - 4, left + 24, y - 4, Hex(SpeedColor(0.5)).c_str());
  DrawText(out, left + 32, y, "… beneath a level");
  y += 20;
  out << Fmt(
      "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"5\" fill=\"white\" stroke=\"black\" "
      "stroke-width=\"2\"/>\n",
      left + 12, y - 4);
  DrawText(out, left + 32, y, "start");
  y += 20;
  out << Fmt("<circle cx=\"%.1f\" cy=\"%.1f\" r=\"5\" fill=\"black\"/>\n", left + 12, y - 4);
  DrawText(out, left + 32, y, "goal");
}

// Height range of the side view: everything drawn, with a margin.
HeightRange SideHeights(const std::vector<Sample>& samples) {
  HeightRange range{std::numeric_limits<double>::max(), std::numeric_limits<double>::lowest()};
  for (const Sample& s : samples) {
    range.lo = std::min({range.lo, s.ground_m, s.position_m.z()});
    range.hi = std::max({range.hi, s.position_m.z(), s.body_top_m});
    if (!std::isnan(s.ceiling_m)) range.hi = std::max(range.hi, s.ceiling_m);
  }
  const double margin = 0.1 * (range.hi - range.lo) + 0.1;
  return {range.lo - margin, range.hi + margin};
}

// Ceiling runs (samples with a drawn ceiling), each filled up to the panel's top.
void DrawCeilings(std::ostringstream& out, const Frame& f, const std::vector<Sample>& samples) {
  const auto on_ceiling = [&](std::size_t i) {
    return std::pair{f.X(samples[i].arc_m), f.Y(samples[i].ceiling_m)};
  };
  for (std::size_t first = 0; first < samples.size();) {
    if (std::isnan(samples[first].ceiling_m)) {
      ++first;
      continue;
    }
    std::size_t last = first;
    while (last + 1 < samples.size() && !std::isnan(samples[last + 1].ceiling_m)) ++last;
    out << Fmt("<polygon fill=\"%s\" stroke=\"none\" points=\"%.1f,%.1f ", kCeilingFill,
               f.X(samples[first].arc_m), f.top_px)
        << Points(first, last, on_ceiling)
        << Fmt(" %.1f,%.1f\"/>\n", f.X(samples[last].arc_m), f.top_px);
    out << Fmt("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"",
               kCeilingStroke)
        << Points(first, last, on_ceiling) << "\"/>\n";
    first = last + 1;
  }
}

void DrawSideView(std::ostringstream& out, const Frame& f, const std::vector<Sample>& samples) {
  const std::size_t last = samples.size() - 1;
  const auto on_ground = [&](std::size_t i) {
    return std::pair{f.X(samples[i].arc_m), f.Y(samples[i].ground_m)};
  };
  out << Fmt("<polygon fill=\"%s\" stroke=\"none\" points=\"%.1f,%.1f ", kGroundFill, f.left_px,
             f.bottom_px())
      << Points(0, last, on_ground)
      << Fmt(" %.1f,%.1f\"/>\n", f.X(samples[last].arc_m), f.bottom_px());
  out << Fmt("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" points=\"", kGroundStroke)
      << Points(0, last, on_ground) << "\"/>\n";
  DrawCeilings(out, f, samples);
  out << Fmt("<polyline fill=\"none\" stroke=\"%s\" stroke-width=\"1.5\" stroke-dasharray=\"6 3\" "
             "points=\"",
             kBodyStroke)
      << Points(0, last,
                [&](std::size_t i) {
                  return std::pair{f.X(samples[i].arc_m), f.Y(samples[i].body_top_m)};
                })
      << "\"/>\n";
  out << "<polyline fill=\"none\" stroke=\"black\" stroke-width=\"2\" points=\""
      << Points(0, last,
                [&](std::size_t i) {
                  return std::pair{f.X(samples[i].arc_m), f.Y(samples[i].position_m.z())};
                })
      << "\"/>\n";
}

void DrawSideLegend(std::ostringstream& out, double left, double top) {
  double y = top;
  out << Fmt("<rect x=\"%.1f\" y=\"%.1f\" width=\"24\" height=\"10\" fill=\"%s\" stroke=\"%s\"/>\n",
             left, y - 9, kCeilingFill, kCeilingStroke);
  DrawText(out, left + 32, y, "ceiling");
  y += 20;
  out << Fmt(
      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
      "stroke-width=\"1.5\" stroke-dasharray=\"6 3\"/>\n",
      left, y - 4, left + 24, y - 4, kBodyStroke);
  DrawText(out, left + 32, y, "body top");
  y += 20;
  out << Fmt(
      "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"black\" "
      "stroke-width=\"2\"/>\n",
      left, y - 4, left + 24, y - 4);
  DrawText(out, left + 32, y, "reference point");
  y += 20;
  out << Fmt("<rect x=\"%.1f\" y=\"%.1f\" width=\"24\" height=\"10\" fill=\"%s\" stroke=\"%s\"/>\n",
             left, y - 9, kGroundFill, kGroundStroke);
  DrawText(out, left + 32, y, "ground");
}

// Says how much the side view stretches heights, since its metres are not square.
std::string SideCaption(const Frame& f) {
  const double stretch = (f.height_px / (f.y_max - f.y_min)) / (f.width_px / (f.x_max - f.x_min));
  std::string caption = "Side view: heights along the trajectory";
  if (stretch > 1.05) caption += Fmt(" (heights stretched %.1f×)", stretch);
  if (stretch < 0.95) caption += Fmt(" (heights shrunk %.1f×)", 1 / stretch);
  return caption;
}

// Metric bounds of the top view: the traversable ground with a margin.
Frame TopFrame(const SurfaceGraph& graph, double top_px) {
  Eigen::AlignedBox2d box;
  for (int n = 0; n < graph.node_count(); ++n) box.extend(graph.position(n).head<2>());
  const double margin = 0.5 + graph.grid().resolution_m;
  box.min().array() -= margin;
  box.max().array() += margin;
  const Eigen::Vector2d extent = box.sizes();
  const double px_per_m = std::min(kPlotWidth / extent.x(), kTopViewMaxHeight / extent.y());
  return {kMarginLeft,   top_px,        extent.x() * px_per_m, extent.y() * px_per_m,
          box.min().x(), box.max().x(), box.min().y(),         box.max().y()};
}

void DrawTitle(std::ostringstream& out, const PlanResult& plan, const RobotProfile& profile,
               const std::string& map_name) {
  const PlanStats& s = plan.stats;
  DrawText(out, kMarginLeft, 26, "Strata plan on " + map_name + ", robot " + profile.name, "start",
           " font-size=\"17\" font-weight=\"bold\"");
  DrawText(out, kMarginLeft, 48,
           Fmt("length %.2f m · duration %.2f s · %d pieces · planned in %.3f s (search %.3f s, "
               "optimise %.3f s)",
               s.length_m, s.duration_s, s.pieces, s.timings.total_s, s.timings.search_s,
               s.timings.optimize_s),
           "start", " font-size=\"13\"");
}

}  // namespace

std::string RenderPlanSvg(const SurfaceGraph& graph, const PlanResult& plan,
                          const RobotProfile& profile, const std::string& map_name) {
  const std::vector<Sample> samples = SampleTrajectory(graph, plan, profile);
  double speed_scale = profile.max_speed_horizontal_mps;
  for (const Sample& s : samples) speed_scale = std::max(speed_scale, s.speed_mps);
  const HeightRange ground = GroundHeights(graph);

  const Frame top = TopFrame(graph, kTitleHeight);
  const double side_top = top.top_px + std::max(top.height_px, kTopLegendHeight) + kPanelGap;
  const HeightRange side_z = SideHeights(samples);
  const Frame side{kMarginLeft,     side_top, kPlotWidth,
                   kSideViewHeight, 0,        std::max(samples.back().arc_m, 1e-3),
                   side_z.lo,       side_z.hi};
  const double legend_left = kMarginLeft + kPlotWidth + kLegendGap;
  const double width = legend_left + kLegendWidth;
  const double height = side.bottom_px() + kMarginBottom;

  std::ostringstream out;
  out << Fmt(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"%.0f\" height=\"%.0f\" "
      "viewBox=\"0 0 %.0f %.0f\" font-family=\"sans-serif\" font-size=\"12\">\n",
      width, height, width, height);
  out << "<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n";
  DrawTitle(out, plan, profile, map_name);

  DrawText(out, top.left_px, top.top_px - 8,
           "Top view: traversable ground shaded by height (upper levels drawn over lower ones)");
  DrawGround(out, top, graph, ground);
  DrawSearchPath(out, top, plan.path);
  DrawTrajectoryTop(out, top, samples, speed_scale);
  DrawEndpoint(out, top, samples.front(), plan.start.level, "start", false);
  DrawEndpoint(out, top, samples.back(), plan.goal.level, "goal", true);
  DrawAxes(out, top, "x [m]", "y [m]", 10, 10);
  DrawTopLegend(out, legend_left, top.top_px + 8, speed_scale, ground);

  DrawText(out, side.left_px, side.top_px - 8, SideCaption(side));
  DrawSideView(out, side, samples);
  DrawAxes(out, side, "arc length along the trajectory [m]", "z [m]", 10, 5);
  DrawSideLegend(out, legend_left, side.top_px + 12);
  out << "</svg>\n";
  return out.str();
}

}  // namespace strata::offline
