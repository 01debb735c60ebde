#include "strata/io/model_tiles.hpp"

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "strata/assessment/map_edit.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/prism.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "test_util/model_bytes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

std::vector<std::string_view> Views(const std::vector<std::string>& parts) {
  return {parts.begin(), parts.end()};
}

// The parking garage at 0.2 m: a grid of about 250 × 150 columns, 4 × 3 tiles, the last
// row and column of them narrower than kTileColumns.
class ModelTiles : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    cloud_ = new PointCloud(GenerateParkingGarage(1, 0.2));
    AssessmentConfig config;
    config.grid.resolution_m = 0.2;
    auto model = TerrainModel::Assess(*cloud_, config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    model_ = new std::shared_ptr<const TerrainModel>(*model);
  }
  static void TearDownTestSuite() {
    delete cloud_;
    delete model_;
  }
  static const PointCloud& cloud() { return *cloud_; }
  static const TerrainModel& model() { return **model_; }

  // A 2 m block on the ground floor in the garage's first tile row.
  static Eigen::AlignedBox3d EditedBlock() {
    return {Eigen::Vector3d(6, 6, 0), Eigen::Vector3d(8, 8, 1)};
  }
  // The garage with that block added: its cloud, and its model reassessed around the block.
  static std::pair<PointCloud, Reassessment> Edited() {
    const std::vector<MapEdit> edits = {{MapEdit::Kind::kAddObstacle, BoxPrism(EditedBlock())}};
    auto edited = ApplyEdits(cloud(), edits, model());
    EXPECT_TRUE(edited.ok()) << edited.error().message;
    if (!edited) return {};
    auto reassessed = ReassessRegion(model(), cloud(), *edited, EditBounds(edits));
    EXPECT_TRUE(reassessed.ok()) << reassessed.error().message;
    if (!reassessed) return {};
    return {std::move(edited).value(), std::move(reassessed).value()};
  }

  // Whether tile `t` of the model's grid lies farther than `margin_m` from `box` in x or y.
  static bool TileFarFrom(std::size_t t, const Eigen::AlignedBox3d& box, double margin_m) {
    const GridGeometry& g = model().grid();
    const int blocks_x = (g.size.x() + kTileColumns - 1) / kTileColumns;
    const double edge = kTileColumns * g.resolution_m;
    const double x0 = g.origin_m.x() + double(t % blocks_x) * edge;
    const double y0 = g.origin_m.y() + double(t / blocks_x) * edge;
    return x0 > box.max().x() + margin_m || x0 + edge < box.min().x() - margin_m ||
           y0 > box.max().y() + margin_m || y0 + edge < box.min().y() - margin_m;
  }

 private:
  static PointCloud* cloud_;
  static std::shared_ptr<const TerrainModel>* model_;
};

PointCloud* ModelTiles::cloud_ = nullptr;
std::shared_ptr<const TerrainModel>* ModelTiles::model_ = nullptr;

TEST_F(ModelTiles, JoinedTilesSaveToTheSameBytes) {
  const TiledModel tiled = CutModel(model());
  ASSERT_EQ(tiled.tiles.size(), TileCount(model().grid()));
  ASSERT_GT(tiled.tiles.size(), 4u);
  ASSERT_NE(model().grid().size.x() % kTileColumns, 0) << "no narrow edge tile to cover";
  const auto joined = JoinModel(tiled.header, Views(tiled.tiles), "garage");
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  EXPECT_TRUE(SerializeModel(**joined) == SerializeModel(model()));
}

TEST_F(ModelTiles, AnEditChangesOnlyTheTilesAroundIt) {
  const auto [edited, reassessed] = Edited();
  ASSERT_NE(reassessed.model, nullptr);
  ASSERT_EQ(reassessed.path, ReassessmentPath::kLocal);

  const TiledModel before = CutModel(model());
  const TiledModel after = CutModel(*reassessed.model);
  const std::vector<std::string> cloud_before = CutCloud(cloud(), model().grid());
  const std::vector<std::string> cloud_after = CutCloud(edited, model().grid());
  std::size_t changed = 0;
  for (std::size_t t = 0; t < before.tiles.size(); ++t) {
    if (before.tiles[t] != after.tiles[t]) ++changed;
    // The assessment's reach (the distance cap, the diffusion) is well under a tile.
    if (TileFarFrom(t, EditedBlock(), 4.0)) {
      EXPECT_TRUE(before.tiles[t] == after.tiles[t]) << "model tile " << t;
      EXPECT_TRUE(cloud_before[t] == cloud_after[t]) << "cloud tile " << t;
    }
  }
  EXPECT_GE(changed, 1u);
  EXPECT_LE(changed, 4u) << "of " << before.tiles.size();
  // And the base's tiles with the edit's own join to the reassessed model.
  const auto joined = JoinModel(after.header, Views(after.tiles), "edited");
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  EXPECT_TRUE(SerializeModel(**joined) == SerializeModel(*reassessed.model));
}

// JoinModel of `tiled` holding `held`, from a source that notes in `asked` each tile it gives.
Expected<std::shared_ptr<const TerrainModel>> JoinHolding(const TiledModel& tiled,
                                                          const HeldTiles& held,
                                                          std::vector<std::size_t>* asked) {
  std::uint64_t bytes = 0;
  for (const std::string& tile : tiled.tiles) bytes += tile.size();
  const TileSource source = [&](std::size_t t) -> Expected<std::string> {
    asked->push_back(t);
    return tiled.tiles[t];
  };
  return JoinModel(tiled.header, tiled.tiles.size(), bytes, source, "held", &held);
}

TEST_F(ModelTiles, AJoinTakesTheTilesItHoldsFromTheModelInMemoryAndReadsTheRest) {
  const auto [edited, reassessed] = Edited();
  ASSERT_NE(reassessed.model, nullptr);
  const TiledModel before = CutModel(model());
  const TiledModel after = CutModel(*reassessed.model);
  const auto same = [&](std::size_t t) { return before.tiles[t] == after.tiles[t]; };
  std::vector<std::size_t> changed;
  for (std::size_t t = 0; t < after.tiles.size(); ++t) {
    if (!same(t)) changed.push_back(t);
  }
  ASSERT_FALSE(changed.empty());
  // The edited version joined on a replica that holds the base: only the changed tiles read.
  std::vector<std::size_t> asked;
  const auto joined = JoinHolding(after, HeldTiles{&model(), same}, &asked);
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  EXPECT_TRUE(SerializeModel(**joined) == SerializeModel(*reassessed.model));
  EXPECT_EQ(asked, changed);
  // And back: the base joined on a replica that holds the edited version.
  asked.clear();
  const auto back = JoinHolding(before, HeldTiles{reassessed.model.get(), same}, &asked);
  ASSERT_TRUE(back.ok()) << back.error().message;
  EXPECT_TRUE(SerializeModel(**back) == SerializeModel(model()));
  EXPECT_EQ(asked, changed);
}

// The most valid surfaces in one column of `model`, counted column by column.
int MostLevelsCounted(const TerrainModel& model) {
  int most = 0;
  for (int iy = 0; iy < model.grid().size.y(); ++iy) {
    for (int ix = 0; ix < model.grid().size.x(); ++ix) {
      int valid = 0;
      for (const ColumnSurface& s : model.surfaces().Column(ix, iy)) valid += s.valid;
      most = std::max(most, valid);
    }
  }
  return most;
}

// Whether `a` holds the very chunks of `b` (not copies) in the row of chunks `k`.
bool SharesChunk(const TerrainModel& a, const TerrainModel& b, std::size_t k) {
  return a.surfaces().chunks()[k] == b.surfaces().chunks()[k] &&
         a.fields().chunks()[k] == b.fields().chunks()[k];
}

TEST_F(ModelTiles, AnEditAndAJoinShareTheChunksOfTheRowsTheyDidNotChange) {
  const auto [edited, reassessed] = Edited();
  ASSERT_NE(reassessed.model, nullptr);
  const TiledModel before = CutModel(model());
  const TiledModel after = CutModel(*reassessed.model);
  const GridGeometry& g = model().grid();
  const std::size_t blocks_x = (g.size.x() + kTileColumns - 1) / kTileColumns;
  ASSERT_EQ(static_cast<std::size_t>(ChunkCount(g)), before.tiles.size() / blocks_x);
  ASSERT_GE(ChunkCount(g), 3);
  std::vector<std::size_t> asked;
  const auto joined = JoinHolding(
      after, HeldTiles{&model(), [&](std::size_t t) { return before.tiles[t] == after.tiles[t]; }},
      &asked);
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  int shared = 0;
  for (std::size_t k = 0; k < static_cast<std::size_t>(ChunkCount(g)); ++k) {
    bool row_changed = false;
    for (std::size_t t = k * blocks_x; t < (k + 1) * blocks_x; ++t) {
      row_changed = row_changed || before.tiles[t] != after.tiles[t];
    }
    // The edit's model and a replica's join of it, holding the base, share the base's chunks
    // of every row of tiles the edit left alone, and make new ones of the others.
    EXPECT_EQ(SharesChunk(*reassessed.model, model(), k), !row_changed) << "chunk " << k;
    EXPECT_EQ(SharesChunk(**joined, model(), k), !row_changed) << "chunk " << k;
    shared += !row_changed;
  }
  EXPECT_GE(shared, 2) << "the edit lies in one row of tiles";
  // What making them allocated beyond the base: the changed row's chunks alone.
  EXPECT_LT(model().MemoryBytesBeyond(model()), 1024u) << "the chunks' pointers";
  for (const TerrainModel* made : {reassessed.model.get(), joined->get()}) {
    EXPECT_GT(made->MemoryBytesBeyond(model()), made->MemoryBytes() / 10);
    EXPECT_LT(made->MemoryBytesBeyond(model()), made->MemoryBytes() / 2);
  }
  // The levels' count comes with a shared chunk and is counted for a new one.
  EXPECT_GE(model().surfaces().max_valid_levels(), 2) << "the garage has decks";
  EXPECT_EQ(model().surfaces().max_valid_levels(), MostLevelsCounted(model()));
  EXPECT_EQ((*joined)->surfaces().max_valid_levels(), MostLevelsCounted(**joined));
  EXPECT_EQ(reassessed.model->surfaces().max_valid_levels(), MostLevelsCounted(*reassessed.model));
}

TEST_F(ModelTiles, AHeldModelOfAnotherGridIsNotTakenFrom) {
  // The garage's model at 0.4 m: the same site, other columns under every tile number.
  AssessmentConfig config;
  config.grid.resolution_m = 0.4;
  const auto coarse = TerrainModel::Assess(cloud(), config);
  ASSERT_TRUE(coarse.ok()) << coarse.error().message;
  const TiledModel tiled = CutModel(model());
  std::vector<std::size_t> asked;
  const auto joined =
      JoinHolding(tiled, HeldTiles{coarse->get(), [](std::size_t) { return true; }}, &asked);
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  EXPECT_TRUE(SerializeModel(**joined) == SerializeModel(model()));
  EXPECT_EQ(asked.size(), tiled.tiles.size());
}

TEST_F(ModelTiles, ACloudJoinsFromItsTilesInTileOrderAndAssessesTheSame) {
  const std::vector<std::string> tiles = CutCloud(cloud(), model().grid());
  const auto joined = JoinCloud(Views(tiles), "garage");
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  ASSERT_EQ(joined->size(), cloud().size());
  EXPECT_FALSE(*joined == cloud()) << "tile order should differ from the scene's";
  const auto key = [](const Eigen::Vector3f& p) { return std::tuple(p.x(), p.y(), p.z()); };
  const auto less = [&](const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
    return key(a) < key(b);
  };
  PointCloud a = cloud(), b = *joined;
  std::sort(a.begin(), a.end(), less);
  std::sort(b.begin(), b.end(), less);
  EXPECT_TRUE(a == b);
  // A store hands the joined cloud to the next edit: its model must be the same.
  const auto model_of_joined = TerrainModel::Assess(*joined, model().config());
  ASSERT_TRUE(model_of_joined.ok());
  EXPECT_TRUE(test_util::BytesWithoutTimings(**model_of_joined) ==
              test_util::BytesWithoutTimings(model()));
}

// An edit cuts only the tiles it changed (CutCloudTiles): each tile, and tiles far apart,
// cut alone as the whole cut cuts them, with points on the tiles' borders and past the grid's
// edges (which belong to the edge's tiles) too.
TEST_F(ModelTiles, SomeTilesCutAsTheWholeCutCutsThemBordersAndPointsPastTheGridIncluded) {
  const GridGeometry& g = model().grid();
  PointCloud points = cloud();
  const double r = g.resolution_m;
  const Eigen::Vector3d far = g.origin_m + g.size.cast<double>() * r;
  for (const double nudge : {-1e-4, 0.0, 1e-4}) {
    const double border_x = g.origin_m.x() + kTileColumns * r + nudge;
    const double border_y = g.origin_m.y() + kTileColumns * r + nudge;
    points.emplace_back(static_cast<float>(border_x), static_cast<float>(g.origin_m.y() + 1), 0.f);
    points.emplace_back(static_cast<float>(g.origin_m.x() + 1), static_cast<float>(border_y), 0.f);
  }
  points.emplace_back(static_cast<float>(g.origin_m.x() - 3), static_cast<float>(far.y() + 3), 0.f);
  points.emplace_back(static_cast<float>(far.x() + 3), static_cast<float>(g.origin_m.y() - 3), 0.f);
  points.emplace_back(static_cast<float>(far.x() + 3), static_cast<float>(far.y() + 3), 0.f);
  const std::vector<std::string> whole = CutCloud(points, g);
  ASSERT_GE(whole.size(), 6U);
  std::size_t bytes = 0;
  for (const std::string& tile : whole) bytes += tile.size();
  EXPECT_EQ(bytes, points.size() * 3 * sizeof(float)) << "every point is in a tile";
  std::vector<std::vector<std::size_t>> subsets;
  for (std::size_t t = 0; t < whole.size(); ++t) subsets.push_back({t});
  subsets.push_back({0, whole.size() - 1});
  subsets.push_back({1, whole.size() - 2});
  for (const std::vector<std::size_t>& which : subsets) {
    const std::vector<std::string> some = CutCloudTiles(points, g, which);
    ASSERT_EQ(some.size(), which.size());
    for (std::size_t k = 0; k < which.size(); ++k) {
      EXPECT_TRUE(some[k] == whole[which[k]]) << "tile " << which[k] << ": " << some[k].size()
                                              << " bytes against " << whole[which[k]].size();
    }
  }
}

// A store joins a cloud a tile at a time as it reads them: the same cloud, and a tile it
// cannot read or that is not whole points fails the join naming it.
TEST_F(ModelTiles, ACloudJoinedFromASourceIsTheCloudOfItsTilesAndPassesOnItsErrors) {
  const std::vector<std::string> tiles = CutCloud(cloud(), model().grid());
  std::uint64_t bytes = 0;
  for (const std::string& tile : tiles) bytes += tile.size();
  std::vector<std::size_t> asked;
  const TileSource source = [&](std::size_t t) -> Expected<std::string> {
    asked.push_back(t);
    return tiles[t];
  };
  const auto joined = JoinCloud(tiles.size(), bytes, source, "garage");
  ASSERT_TRUE(joined.ok()) << joined.error().message;
  EXPECT_TRUE(*joined == JoinCloud(Views(tiles), "garage").value());
  EXPECT_EQ(asked.size(), tiles.size());
  EXPECT_TRUE(std::is_sorted(asked.begin(), asked.end()));

  const TileSource failing = [&](std::size_t t) -> Expected<std::string> {
    if (t == 2) return Error{ErrorCode::kMapLoadFailed, "tile 2 is gone"};
    return tiles[t];
  };
  const auto lost = JoinCloud(tiles.size(), bytes, failing, "garage");
  ASSERT_FALSE(lost.ok());
  EXPECT_EQ(lost.error().message, "tile 2 is gone");
  const TileSource ragged = [&](std::size_t t) -> Expected<std::string> {
    return t == 1 ? tiles[t] + "x" : tiles[t];
  };
  const auto broken = JoinCloud(tiles.size(), bytes, ragged, "garage");
  ASSERT_FALSE(broken.ok());
  EXPECT_THAT(broken.error().message, HasSubstr("garage tile 1 is not a whole number of points"));
}

TEST_F(ModelTiles, RefusesWhatDoesNotFitNamingTheTile) {
  const TiledModel tiled = CutModel(model());
  std::vector<std::string_view> tiles = Views(tiled.tiles);
  const auto refusal = [&](std::string_view header, std::span<const std::string_view> parts) {
    const auto joined = JoinModel(header, parts, "m7");
    EXPECT_FALSE(joined.ok());
    if (joined.ok()) return std::string("joined");
    EXPECT_EQ(joined.error().code, ErrorCode::kMapLoadFailed);
    EXPECT_THAT(joined.error().message, HasSubstr("m7"));
    return joined.error().message;
  };
  EXPECT_THAT(refusal(tiled.header, std::span(tiles).first(tiles.size() - 1)),
              HasSubstr("needs " + std::to_string(tiles.size())));
  std::string header = tiled.header;
  header[header.size() / 2] ^= 1;
  EXPECT_THAT(refusal(header, tiles), HasSubstr("checksum"));
  EXPECT_THAT(refusal(tiled.header.substr(0, 20), tiles), Not(HasSubstr("joined")));

  for (std::size_t t : {std::size_t{0}, tiles.size() - 1}) {
    const std::string original(tiles[t]);
    const std::string shorter = original.substr(0, original.size() - 1);
    const std::string longer = original + "x";
    const std::string truncated = original.substr(0, 10);
    for (const std::string* bad : {&shorter, &longer, &truncated}) {
      tiles[t] = *bad;
      EXPECT_THAT(refusal(tiled.header, tiles), HasSubstr("tile " + std::to_string(t)));
    }
    tiles[t] = tiled.tiles[t];
  }
  // A tile whose counts add up but whose layers leave the grid: the model's own checks.
  std::string runs = tiled.tiles[0];
  const std::size_t columns = kTileColumns * kTileColumns;
  std::size_t surfaces = 0;
  for (std::size_t c = 0; c < columns; ++c) {
    std::uint32_t n;
    std::memcpy(&n, runs.data() + 4 * c, 4);
    surfaces += n;
  }
  const std::size_t first_run = 4 * columns + 25 * surfaces + 4 * columns;
  const std::int32_t far_layer = 1 << 20;
  std::memcpy(runs.data() + first_run, &far_layer, 4);
  tiles[0] = runs;
  EXPECT_THAT(refusal(tiled.header, tiles), HasSubstr("inconsistent"));
  tiles[0] = tiled.tiles[0];

  const std::vector<std::string> cloud_tiles = {std::string(12, '\0'), std::string(13, '\0')};
  const auto cloud = JoinCloud(Views(cloud_tiles), "c7");
  ASSERT_FALSE(cloud.ok());
  EXPECT_THAT(cloud.error().message, HasSubstr("c7 tile 1"));
}

}  // namespace
}  // namespace strata
