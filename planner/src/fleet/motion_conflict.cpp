#include "strata/fleet/motion_conflict.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include <fmt/format.h>

#include "format_internal.hpp"

namespace strata {
namespace fleet_internal {

/// One stretch of a motion over which it follows one polynomial: a trajectory piece or the
/// parked time after the last. Times are seconds from the motion's start.
struct BoundedPiece {
  double begin_s = 0;
  double end_s = 0;
  const TrajectoryPiece* piece = nullptr;  // Null: parked at `parked`.
  StateVector parked;
  // Bounds over the whole stretch (Bernstein hull), to rule pairs out cheaply.
  double min_x = 0, max_x = 0, min_y = 0, max_y = 0;
  double min_bottom = 0, max_top = 0;
};

}  // namespace fleet_internal
namespace {

using fleet_internal::BoundedPiece;

constexpr int kPieceDegree = 5;
constexpr int kDistanceDegree = 2 * kPieceDegree;
// A stretch halved this often spans 2^-52 of its length, where its polynomials are constant
// to double precision: the search stops there whatever the bounds say.
constexpr int kMaxHalvings = 52;

/// Coefficients of a polynomial of degree N on u ∈ [0, 1]: monomial (lowest order first) or
/// Bernstein, as the name of the variable says.
template <int N>
using Coefficients = std::array<double, N + 1>;
using Quintic = Coefficients<kPieceDegree>;
using Decic = Coefficients<kDistanceDegree>;

/// The motion's polynomials on one window, in u ∈ [0, 1]: x, y, and the body's bottom and top.
struct WindowPolynomials {
  Quintic x{}, y{}, bottom{}, top{};
};

template <int N>
double Binomial(int n, int k) {
  static const auto table = [] {
    std::array<std::array<double, N + 1>, N + 1> c{};
    for (int i = 0; i <= N; ++i) {
      c[i][0] = 1;
      for (int j = 1; j <= i; ++j) c[i][j] = c[i - 1][j - 1] + (j < i ? c[i - 1][j] : 0);
    }
    return c;
  }();
  return table[n][k];
}

/// Bernstein coefficients of the polynomial with monomial coefficients `q` on [0, 1].
template <int N>
Coefficients<N> ToBernstein(const Coefficients<N>& q) {
  Coefficients<N> b{};
  for (int i = 0; i <= N; ++i) {
    for (int k = 0; k <= i; ++k) b[i] += Binomial<N>(i, k) / Binomial<N>(N, k) * q[k];
  }
  return b;
}

/// Splits Bernstein coefficients at u = 1/2 into those of the two halves (de Casteljau).
template <int N>
void Halve(const Coefficients<N>& b, Coefficients<N>* left, Coefficients<N>* right) {
  Coefficients<N> w = b;
  (*left)[0] = w[0];
  (*right)[N] = w[N];
  for (int r = 1; r <= N; ++r) {
    for (int i = 0; i <= N - r; ++i) w[i] = 0.5 * (w[i] + w[i + 1]);
    (*left)[r] = w[0];
    (*right)[N - r] = w[N - r];
  }
}

template <int N>
std::pair<double, double> Range(const Coefficients<N>& b) {
  const auto [lo, hi] = std::minmax_element(b.begin(), b.end());
  return {*lo, *hi};
}

/// Monomial coefficients in u of axis `axis` of `segment` on the window [tau0, tau0 + h] of
/// its piece's own time.
Quintic AxisOnWindow(const BoundedPiece& segment, int axis, double tau0, double h) {
  Quintic q{};
  if (segment.piece == nullptr) {
    q[0] = segment.parked(axis);
    return q;
  }
  // p(τ0 + h·u) by Horner's rule over polynomials in u.
  const auto& c = segment.piece->coefficients;
  q[0] = c(kPieceDegree, axis);
  for (int k = kPieceDegree - 1; k >= 0; --k) {
    for (int j = kPieceDegree; j >= 1; --j) q[j] = tau0 * q[j] + h * q[j - 1];
    q[0] = tau0 * q[0] + c(k, axis);
  }
  return q;
}

WindowPolynomials OnWindow(const BoundedPiece& segment, const FleetMotion& motion, double tau0,
                           double h) {
  WindowPolynomials w;
  w.x = AxisOnWindow(segment, 0, tau0, h);
  w.y = AxisOnWindow(segment, 1, tau0, h);
  const Quintic z = AxisOnWindow(segment, 2, tau0, h);
  const bool commanded_height = motion.trajectory.dimension == 4;
  const Quintic height = commanded_height ? AxisOnWindow(segment, 3, tau0, h) : Quintic{};
  for (int k = 0; k <= kPieceDegree; ++k) {
    w.bottom[k] = z[k] - (k == 0 ? motion.body.reference_height_m : 0.0);
    w.top[k] = w.bottom[k] + (commanded_height ? height[k] : (k == 0 ? motion.body.height_m : 0));
  }
  return w;
}

void SetBounds(const FleetMotion& motion, BoundedPiece* segment) {
  const WindowPolynomials w = OnWindow(*segment, motion, 0, segment->end_s - segment->begin_s);
  std::tie(segment->min_x, segment->max_x) = Range<kPieceDegree>(ToBernstein<kPieceDegree>(w.x));
  std::tie(segment->min_y, segment->max_y) = Range<kPieceDegree>(ToBernstein<kPieceDegree>(w.y));
  segment->min_bottom = Range<kPieceDegree>(ToBernstein<kPieceDegree>(w.bottom)).first;
  segment->max_top = Range<kPieceDegree>(ToBernstein<kPieceDegree>(w.top)).second;
}

bool OutOfReach(const BoundedPiece& a, const BoundedPiece& b, double limit_m) {
  const double gap_x = std::max({0.0, a.min_x - b.max_x, b.min_x - a.max_x});
  const double gap_y = std::max({0.0, a.min_y - b.max_y, b.min_y - a.max_y});
  return gap_x * gap_x + gap_y * gap_y >= limit_m * limit_m || a.max_top <= b.min_bottom ||
         b.max_top <= a.min_bottom;
}

/// What a conflict needs on a window, each as Bernstein coefficients over u ∈ [0, 1]: all
/// three positive at once.
struct ConflictFunctions {
  Decic closeness{};   // limit² − horizontal distance²
  Quintic a_over_b{};  // a's top − b's bottom
  Quintic b_over_a{};  // b's top − a's bottom
};

ConflictFunctions OnWindow(const WindowPolynomials& a, const WindowPolynomials& b, double limit_m) {
  Quintic dx{}, dy{};
  for (int k = 0; k <= kPieceDegree; ++k) {
    dx[k] = a.x[k] - b.x[k];
    dy[k] = a.y[k] - b.y[k];
  }
  Decic closeness{};
  closeness[0] = limit_m * limit_m;
  for (int i = 0; i <= kPieceDegree; ++i) {
    for (int j = 0; j <= kPieceDegree; ++j) closeness[i + j] -= dx[i] * dx[j] + dy[i] * dy[j];
  }
  Quintic a_over_b{}, b_over_a{};
  for (int k = 0; k <= kPieceDegree; ++k) {
    a_over_b[k] = a.top[k] - b.bottom[k];
    b_over_a[k] = b.top[k] - a.bottom[k];
  }
  return {ToBernstein<kDistanceDegree>(closeness), ToBernstein<kPieceDegree>(a_over_b),
          ToBernstein<kPieceDegree>(b_over_a)};
}

/// The first u ∈ [0, 1] at which the functions are all positive, within the tolerances
/// (see motion_conflict.hpp), earliest first by halving.
std::optional<double> FirstPositive(const ConflictFunctions& window, double closeness_tolerance,
                                    double vertical_tolerance) {
  struct Stretch {
    ConflictFunctions f;
    double u0, u1;
    int halvings;
  };
  std::vector<Stretch> stack{{window, 0.0, 1.0, 0}};
  while (!stack.empty()) {
    const Stretch s = stack.back();
    stack.pop_back();
    const auto [close_min, close_max] = Range<kDistanceDegree>(s.f.closeness);
    const auto [ab_min, ab_max] = Range<kPieceDegree>(s.f.a_over_b);
    const auto [ba_min, ba_max] = Range<kPieceDegree>(s.f.b_over_a);
    if (close_max <= 0 || ab_max <= 0 || ba_max <= 0) continue;  // Ruled out throughout.
    // The first coefficient is the value at u0: a conflict there is exact.
    if (s.f.closeness[0] > 0 && s.f.a_over_b[0] > 0 && s.f.b_over_a[0] > 0) return s.u0;
    // Each range holds its value at u0 and reaches above 0: narrow ranges put u0 within the
    // tolerances of a conflict.
    const bool narrow = close_max - close_min <= closeness_tolerance &&
                        ab_max - ab_min <= vertical_tolerance &&
                        ba_max - ba_min <= vertical_tolerance;
    if (narrow || s.halvings == kMaxHalvings) return s.u0;
    Stretch left{{}, s.u0, 0.5 * (s.u0 + s.u1), s.halvings + 1};
    Stretch right{{}, left.u1, s.u1, s.halvings + 1};
    Halve<kDistanceDegree>(s.f.closeness, &left.f.closeness, &right.f.closeness);
    Halve<kPieceDegree>(s.f.a_over_b, &left.f.a_over_b, &right.f.a_over_b);
    Halve<kPieceDegree>(s.f.b_over_a, &left.f.b_over_a, &right.f.b_over_a);
    stack.push_back(right);
    stack.push_back(left);  // Examined first: the earlier half.
  }
  return std::nullopt;
}

}  // namespace

Status SeparationRule::Validate(std::string_view path) const {
  const auto check = [&](std::string_view field, double value, bool allow_zero) -> Status {
    if (std::isfinite(value) && (value > 0 || (allow_zero && value == 0))) return Status::Ok();
    const std::string name = internal::FieldPath(path, field);
    return Error{ErrorCode::kInvalidInput,
                 fmt::format("{} = {:g} m must be {} and finite", name, value,
                             allow_zero ? "at least 0" : "positive"),
                 name};
  };
  if (Status s = check("separation_m", separation_m, true); !s) return s;
  if (Status s = check("distance_tolerance_m", distance_tolerance_m, false); !s) return s;
  return check("vertical_tolerance_m", vertical_tolerance_m, false);
}

PreparedMotion::PreparedMotion(const FleetMotion& motion) : motion_(&motion) {
  pieces_.reserve(motion.trajectory.pieces.size() + 1);
  double t = 0;
  for (const TrajectoryPiece& piece : motion.trajectory.pieces) {
    BoundedPiece s;
    s.begin_s = t;
    s.end_s = t + piece.duration_s;
    s.piece = &piece;
    t = s.end_s;
    pieces_.push_back(s);
  }
  const double end_s = SecondsBetween(motion.start_ns, motion.end_ns);
  if (end_s > t) {
    BoundedPiece s;
    s.begin_s = t;
    s.end_s = end_s;
    s.parked = motion.trajectory.Evaluate(motion.trajectory.TotalDuration(), 0);
    pieces_.push_back(s);
  }
  for (BoundedPiece& s : pieces_) SetBounds(motion, &s);
}

PreparedMotion::~PreparedMotion() = default;
PreparedMotion::PreparedMotion(PreparedMotion&&) noexcept = default;
PreparedMotion& PreparedMotion::operator=(PreparedMotion&&) noexcept = default;

std::optional<MotionConflict> FirstConflict(const FleetMotion& a, const FleetMotion& b,
                                            const SeparationRule& rule) {
  return FirstConflict(PreparedMotion(a), PreparedMotion(b), rule);
}

double PairSeparationM(const SeparationRule& rule, const FleetMotion& other) {
  return std::max(rule.separation_m, other.separation_m);
}

double PairSeparationM(const SeparationRule& rule, const FleetMotion& a, const FleetMotion& b) {
  return std::max(PairSeparationM(rule, a), b.separation_m);
}

std::optional<MotionConflict> FirstConflict(const PreparedMotion& prepared_a,
                                            const PreparedMotion& prepared_b,
                                            const SeparationRule& rule) {
  const FleetMotion& a = prepared_a.motion();
  const FleetMotion& b = prepared_b.motion();
  const std::int64_t origin_ns = std::max(a.start_ns, b.start_ns);
  const std::int64_t until_ns = std::min(a.end_ns, b.end_ns);
  if (until_ns < origin_ns) return std::nullopt;  // Never both present.
  const double until_s = SecondsBetween(origin_ns, until_ns);
  const double limit_m = a.body.radius_m + b.body.radius_m + PairSeparationM(rule, a, b);
  const double reach_m = limit_m + rule.distance_tolerance_m;
  const double closeness_tolerance = reach_m * reach_m - limit_m * limit_m;

  // Times from the origin, where both are present: a piece's start is its motion's start
  // (at or before the origin) plus its own.
  const std::vector<BoundedPiece>& sa = prepared_a.pieces();
  const std::vector<BoundedPiece>& sb = prepared_b.pieces();
  const double a_start_s = SecondsBetween(origin_ns, a.start_ns);
  const double b_start_s = SecondsBetween(origin_ns, b.start_ns);
  std::size_t i = 0, j = 0;
  while (i < sa.size() && a_start_s + sa[i].end_s <= 0) ++i;  // Over before the origin.
  while (j < sb.size() && b_start_s + sb[j].end_s <= 0) ++j;
  while (i < sa.size() && j < sb.size()) {
    const BoundedPiece& x = sa[i];
    const BoundedPiece& y = sb[j];
    const double x_begin_s = a_start_s + x.begin_s, x_end_s = a_start_s + x.end_s;
    const double y_begin_s = b_start_s + y.begin_s, y_end_s = b_start_s + y.end_s;
    const double lo = std::max({x_begin_s, y_begin_s, 0.0});
    if (lo > until_s) break;
    const double hi = std::min({x_end_s, y_end_s, until_s});
    // A window of no length is compared only when it is all the time both motions share.
    const bool compare = hi > lo || (hi == lo && until_s == 0);
    if (compare && !OutOfReach(x, y, limit_m)) {
      const double h = hi - lo;
      const ConflictFunctions f =
          OnWindow(OnWindow(x, a, lo - x_begin_s, h), OnWindow(y, b, lo - y_begin_s, h), limit_m);
      if (const std::optional<double> u =
              FirstPositive(f, closeness_tolerance, rule.vertical_tolerance_m)) {
        MotionConflict conflict;
        conflict.time_ns = AddSeconds(origin_ns, lo + *u * h);
        conflict.point_a = a.ReferencePointAt(conflict.time_ns);
        conflict.point_b = b.ReferencePointAt(conflict.time_ns);
        conflict.horizontal_distance_m = (conflict.point_a - conflict.point_b).head<2>().norm();
        conflict.limit_m = limit_m;
        return conflict;
      }
    }
    if (x_end_s < y_end_s) {
      ++i;
    } else {
      ++j;
    }
  }
  return std::nullopt;
}

}  // namespace strata
