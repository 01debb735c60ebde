// ClearanceRanks against a sort: after random removals and additions, with many ties and
// without, the value it gives at a rank is the one nth_element finds there, and where its
// kept values cannot tell, it says so instead of guessing.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "planning/clearance_ranks.hpp"

namespace strata::graph_internal {
namespace {

float TrueAtRank(std::vector<float> values, std::size_t rank) {
  std::nth_element(values.begin(), values.begin() + static_cast<std::ptrdiff_t>(rank),
                   values.end());
  return values[rank];
}

std::vector<SurfaceGraph::Node> NodesOf(const std::vector<float>& clearances) {
  std::vector<SurfaceGraph::Node> nodes;
  for (const float c : clearances) nodes.push_back({0, 0, 0, 0, 0.0f, c});
  return nodes;
}

// Clearances as a map has them: `step` > 0 rounds them to multiples of it (ties by the
// thousand), 0 leaves them continuous.
class Clearances {
 public:
  Clearances(unsigned seed, float step) : random_(seed), step_(step) {}
  float Next() {
    const float c = std::uniform_real_distribution<float>(0.0f, 2.0f)(random_);
    return step_ > 0 ? std::round(c / step_) * step_ : c;
  }
  std::size_t Index(std::size_t size) {
    return std::uniform_int_distribution<std::size_t>(0, size - 1)(random_);
  }

 private:
  std::mt19937 random_;
  float step_;
};

// Counts `values`, then edits them `steps` times (up to `most_changed` values removed and as
// many added, more on one side of the rank than the other, so it drifts), comparing the 10th
// percentile each time. Returns how many times the ranks could tell.
int ExpectTenthPercentilesAsSorted(unsigned seed, float step, std::size_t size, int steps,
                                   std::size_t most_changed) {
  Clearances random(seed, step);
  std::vector<float> values(size);
  for (float& c : values) c = random.Next();
  ClearanceRanks ranks(TrueAtRank(values, values.size() / 10));
  const std::vector<SurfaceGraph::Node> nodes = NodesOf(values);
  // In two passes, as a patch counts row by row.
  ranks.Add(std::span(nodes).first(size / 2));
  ranks.Add(std::span(nodes).subspan(size / 2));
  ranks.Finish();
  int told = 0;
  for (int k = 0; k < steps; ++k) {
    std::vector<float> removed, added;
    const std::size_t changed = 1 + random.Index(most_changed);
    for (std::size_t i = 0; i < changed; ++i) {
      const std::size_t at = random.Index(values.size());
      removed.push_back(values[at]);
      values[at] = values.back();
      values.pop_back();
    }
    // Added values lean low on even steps and high on odd ones: the rank moves both ways.
    for (std::size_t i = 0; i < changed + (k % 3 == 0 ? changed / 2 : 0); ++i) {
      const float c = random.Next();
      added.push_back(k % 2 == 0 ? c / 4 : c);
      values.push_back(added.back());
    }
    ranks.Update(removed, added);
    const std::optional<float> tenth = ranks.AtRank(values.size() / 10);
    if (tenth) {
      ++told;
      EXPECT_EQ(*tenth, TrueAtRank(values, values.size() / 10)) << "step " << k;
    }
  }
  return told;
}

TEST(ClearanceRanks, GivesTheTenthPercentileASortFindsAfterEachEdit) {
  // 200 000 clearances, more than ClearanceRanks keeps on either side.
  static_assert(ClearanceRanks::kKept < 200'000 / 2);
  for (const float step : {0.001f, 0.0f}) {
    SCOPED_TRACE(step);
    const int told = ExpectTenthPercentilesAsSorted(7, step, 200'000, 60, 3'000);
    EXPECT_EQ(told, 60) << "edits of a few thousand values stay within the kept values";
  }
}

TEST(ClearanceRanks, FewValuesAreAllKept) {
  EXPECT_EQ(ExpectTenthPercentilesAsSorted(3, 0.01f, 5'000, 100, 200), 100);
}

TEST(ClearanceRanks, SaysSoWhenTheRankLeavesTheKeptValues) {
  Clearances random(11, 0.0f);
  std::vector<float> values(300'000);
  for (float& c : values) c = random.Next();
  std::sort(values.begin(), values.end());
  const float centre = values[30'000];
  ClearanceRanks ranks(centre);
  ranks.Add(NodesOf(values));
  ranks.Finish();
  // Every value below the centre goes, and a million come in at the top: the 10th percentile
  // lies about 97 000 places above the centre, past the 65 536 kept there.
  const std::vector<float> removed(values.begin(), values.begin() + 30'000);
  values.erase(values.begin(), values.begin() + 30'000);
  const std::vector<float> added(1'000'000, 1.99f);
  values.insert(values.end(), added.begin(), added.end());
  ranks.Update(removed, added);
  EXPECT_EQ(ranks.AtRank(values.size() / 10), std::nullopt);
  // Near the centre, now the lowest value, it still tells.
  EXPECT_EQ(ranks.AtRank(0), centre);
  EXPECT_EQ(ranks.AtRank(1'000), values[1'000]);
}

}  // namespace
}  // namespace strata::graph_internal
