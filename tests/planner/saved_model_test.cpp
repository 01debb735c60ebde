#include "strata/io/saved_model.hpp"

#include <atomic>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <xxhash.h>

#include "strata/planner.hpp"
#include "strata/scenes/paper_scenes.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

class SavedModel : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    // A small model, so that hundreds of corrupted copies are read quickly.
    AssessmentConfig config;
    config.grid.resolution_m = 0.25;
    auto model = TerrainModel::Assess(GenerateTwoLevelRamp(2, 0.2), config);
    ASSERT_TRUE(model.ok()) << model.error().message;
    model_ = new std::shared_ptr<const TerrainModel>(*model);
    bytes_ = new std::string(SerializeModel(**model_));
  }
  static void TearDownTestSuite() {
    delete model_;
    delete bytes_;
  }
  static const TerrainModel& model() { return **model_; }
  static const std::string& bytes() { return *bytes_; }

  static Error RefusalOf(std::string_view bytes) {
    const auto loaded = DeserializeModel(bytes, "test.stratamodel");
    EXPECT_FALSE(loaded.ok());
    if (loaded.ok()) return Error{ErrorCode::kInvalidInput, "loaded"};
    EXPECT_EQ(loaded.error().code, ErrorCode::kMapLoadFailed);
    EXPECT_THAT(loaded.error().message, HasSubstr("test.stratamodel"));
    return loaded.error();
  }

 private:
  static std::shared_ptr<const TerrainModel>* model_;
  static std::string* bytes_;
};

std::shared_ptr<const TerrainModel>* SavedModel::model_ = nullptr;
std::string* SavedModel::bytes_ = nullptr;

// Rewrites the checksum after an edit, as a deliberately crafted file would.
void Rechecksum(std::string* bytes) {
  const std::uint64_t digest = XXH3_64bits(bytes->data(), bytes->size() - 8);
  std::memcpy(bytes->data() + bytes->size() - 8, &digest, 8);
}

TEST_F(SavedModel, RoundTripsEveryPartAndTheSameBytes) {
  ASSERT_TRUE(IsSavedModel(bytes()));
  const auto loaded = DeserializeModel(bytes(), "garage");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const TerrainModel& copy = **loaded;
  const ColumnSurfaces copied = copy.surfaces().ToParts();
  const ColumnSurfaces original_surfaces = model().surfaces().ToParts();
  EXPECT_EQ(copied.column_begin, original_surfaces.column_begin);
  ASSERT_EQ(copied.surfaces.size(), original_surfaces.surfaces.size());
  for (std::size_t i = 0; i < copied.surfaces.size(); ++i) {
    const ColumnSurface& a = copied.surfaces[i];
    const ColumnSurface& b = original_surfaces.surfaces[i];
    ASSERT_TRUE(a.ground_z_m == b.ground_z_m && a.clearance_m == b.clearance_m &&
                a.tilt_rad == b.tilt_rad && a.plane_center_z_m == b.plane_center_z_m &&
                a.top_layer == b.top_layer && a.bottom_layer == b.bottom_layer &&
                a.valid == b.valid)
        << "surface " << i;
  }
  const TerrainFields::Parts f = copy.fields().ToParts();
  const TerrainFields::Parts g = model().fields().ToParts();
  EXPECT_EQ(f.distance, g.distance);
  EXPECT_EQ(f.safety, g.safety);
  EXPECT_EQ(f.column_begin, g.column_begin);
  EXPECT_EQ(f.safety_step, g.safety_step);
  // Every field of the parameters and the summary survives (ForEachField lists them all).
  std::vector<double> original, restored;
  ForEachField(model().config(), [&](const char*, const auto& v) { original.push_back(v); });
  ForEachField(copy.config(), [&](const char*, const auto& v) { restored.push_back(v); });
  ForEachField(model().summary(), [&](const char*, const auto& v) { original.push_back(v); });
  ForEachField(copy.summary(), [&](const char*, const auto& v) { restored.push_back(v); });
  EXPECT_EQ(restored, original);
  EXPECT_EQ(SerializeModel(copy), bytes());
}

TEST(SavedModelPlans, ALoadedModelPlansExactlyLikeTheAssessedOne) {
  // The garage's example queries (four decks, ramps between them) on the model as assessed and
  // as loaded from its saved bytes: the same trajectories, bit for bit.
  const GarageLayout layout = GetGarageLayout();
  AssessmentConfig config;
  config.grid.resolution_m = layout.assessment_resolution_m;
  auto model = TerrainModel::Assess(GenerateParkingGarage(2), config);
  ASSERT_TRUE(model.ok()) << model.error().message;
  const auto loaded = DeserializeModel(SerializeModel(**model), "garage");
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const PlanningMap fresh(*model);
  const PlanningMap restored(*loaded);
  int planned = 0;
  for (const SceneQuery& query : layout.queries) {
    PlanRequest request;
    request.profile = *BuiltinProfile(query.robot);
    request.start.position_m = query.start_m + Eigen::Vector3d(0, 0, 0.3);
    request.goal.position_m = query.goal_m + Eigen::Vector3d(0, 0, 0.3);
    request.options.time_budget_s = 30;  // Not a race: the same work on both.
    const auto a = Plan(fresh, request);
    const auto b = Plan(restored, request);
    ASSERT_EQ(a.ok(), b.ok()) << query.name;
    if (!a.ok()) continue;
    ++planned;
    ASSERT_EQ(a->trajectory.pieces.size(), b->trajectory.pieces.size()) << query.name;
    for (std::size_t i = 0; i < a->trajectory.pieces.size(); ++i) {
      EXPECT_EQ(a->trajectory.pieces[i].duration_s, b->trajectory.pieces[i].duration_s);
      EXPECT_EQ(a->trajectory.pieces[i].coefficients, b->trajectory.pieces[i].coefficients);
    }
  }
  EXPECT_GE(planned, 3);
}

TEST_F(SavedModel, SavesAtomicallyAndLoadsFromAFile) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("strata_saved_model_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "garage.stratamodel").string();
  ASSERT_TRUE(SaveModel(model(), path).ok());
  // Saved over while it is read, again and again: a reader finds the whole file every time,
  // never half of one (the save writes a temporary and renames it over the file).
  std::atomic<bool> saving{true};
  std::thread saver([&] {
    while (saving) ASSERT_TRUE(SaveModel(model(), path).ok());
  });
  for (int read = 0; read < 200; ++read) {
    const auto whole = LoadModel(path);
    ASSERT_TRUE(whole.ok()) << "read " << read << ": " << whole.error().message;
  }
  saving = false;
  saver.join();
  // Only the saved file: no temporary left behind.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
  const auto loaded = LoadModel(path);
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_EQ(SerializeModel(**loaded), bytes());
  const Status unwritable = SaveModel(model(), (dir / "missing" / "x.stratamodel").string());
  ASSERT_FALSE(unwritable.ok());
  EXPECT_THAT(unwritable.error().message, HasSubstr("cannot write the saved model"));
  EXPECT_THAT(unwritable.error().message, HasSubstr("No such file or directory"));
  // A rename that fails names its own reason (a clean-up after it once said "Success").
  const std::filesystem::path taken = dir / "taken.stratamodel";
  std::filesystem::create_directories(taken / "inside");
  const Status over_a_directory = SaveModel(model(), taken.string());
  ASSERT_FALSE(over_a_directory.ok());
  EXPECT_THAT(over_a_directory.error().message, Not(HasSubstr("Success")));
  EXPECT_THAT(over_a_directory.error().message, HasSubstr("directory"));
  const auto missing = LoadModel((dir / "nothing.stratamodel").string());
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(missing.error().code, ErrorCode::kMapLoadFailed);
  std::filesystem::remove_all(dir);
}

TEST_F(SavedModel, RefusesForeignFilesAndOtherVersions) {
  EXPECT_THAT(RefusalOf("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n").message,
              HasSubstr("not a Strata saved model"));
  EXPECT_THAT(RefusalOf("").message, HasSubstr("not a Strata saved model"));
  // An older build's file (its fields mean something else) and a newer one's.
  for (const std::uint32_t version : {kSavedModelFormatVersion - 1, kSavedModelFormatVersion + 1}) {
    std::string other = bytes();
    std::memcpy(other.data() + 8, &version, 4);
    const Error error = RefusalOf(other);
    EXPECT_THAT(error.message, HasSubstr("format version " + std::to_string(version) + ";"));
    EXPECT_THAT(error.message, HasSubstr("assess the map again"));
  }
}

TEST_F(SavedModel, RefusesEveryTruncationAndTrailingBytes) {
  // Every prefix in the header and the first fields, then a spread through the arrays.
  std::vector<std::size_t> lengths;
  for (std::size_t n = 0; n < 400; ++n) lengths.push_back(n);
  for (std::size_t n = 400; n < bytes().size(); n += bytes().size() / 300) lengths.push_back(n);
  lengths.push_back(bytes().size() - 1);
  for (const std::size_t n : lengths) {
    const Error error = RefusalOf(std::string_view(bytes()).substr(0, n));
    if (n >= 8) {
      ASSERT_THAT(error.message, HasSubstr("truncated")) << n << " bytes";
    }
  }
  EXPECT_THAT(RefusalOf(bytes() + "x").message, HasSubstr("trailing bytes"));
}

TEST_F(SavedModel, RefusesCorruptedBytes) {
  // Seeded random flips anywhere after the magic and version: the checksum catches every one.
  std::mt19937 rng(7);
  std::uniform_int_distribution<std::size_t> position(12, bytes().size() - 1);
  std::uniform_int_distribution<int> bit(0, 7);
  for (int trial = 0; trial < 300; ++trial) {
    std::string corrupted = bytes();
    const std::size_t at = position(rng);
    corrupted[at] = static_cast<char>(corrupted[at] ^ (1 << bit(rng)));
    const Error error = RefusalOf(corrupted);
    ASSERT_TRUE(error.message.find("corrupted") != std::string::npos ||
                error.message.find("truncated") != std::string::npos ||
                error.message.find("header") != std::string::npos)
        << "flip at " << at << ": " << error.message;
  }
}

TEST_F(SavedModel, RefusesInconsistentContentsWithAGoodChecksum) {
  // A crafted file passes the checksum; its contents are checked on their own. Flip bytes
  // deep in the payload (surfaces, intervals, values), fix the checksum, and the reader must
  // refuse or load a model that is still consistent, never crash or read out of bounds
  // (run under a sanitizer to see the latter).
  std::mt19937 rng(11);
  std::uniform_int_distribution<std::size_t> position(64, bytes().size() - 9);
  int refused = 0;
  for (int trial = 0; trial < 300; ++trial) {
    std::string crafted = bytes();
    for (int k = 0; k < 4; ++k) crafted[position(rng)] = static_cast<char>(rng());
    Rechecksum(&crafted);
    const auto loaded = DeserializeModel(crafted, "crafted");
    if (loaded.ok()) {
      // What loads is what the file says, every value of it: saved again, the same bytes.
      EXPECT_EQ(SerializeModel(**loaded), crafted) << "trial " << trial;
      // And it answers queries inside its grid without going astray.
      const GridGeometry& g = (*loaded)->grid();
      (void)(*loaded)->Distance(g.CellCenter(g.size / 2));
      (void)(*loaded)->SafetyPenalty(g.CellCenter(g.size / 3));
      continue;
    }
    ++refused;
    EXPECT_THAT(loaded.error().message, HasSubstr("crafted"));
  }
  // Most bytes are values any number may take; a sizeable share are counts, offsets and
  // intervals that must agree with the rest.
  EXPECT_GT(refused, 30);
  const std::string name = "grid.max_columns";
  const std::size_t at = bytes().find(name);
  ASSERT_NE(at, std::string::npos);
  // An unknown field name.
  std::string renamed = bytes();
  renamed[at] = 'G';
  Rechecksum(&renamed);
  EXPECT_THAT(RefusalOf(renamed).message, HasSubstr("Grid.max_columns"));
  // A length that promises more than the file holds: the name's own length prefix.
  std::string overlong = bytes();
  const std::uint32_t huge = 0x7fffffff;
  std::memcpy(overlong.data() + at - sizeof(huge), &huge, sizeof(huge));
  Rechecksum(&overlong);
  (void)RefusalOf(overlong);
}

// The header alone is read to compare parameters, without the checksum: every truncation and
// every flipped byte of it is refused or read as a whole config, never read past or crashed on.
TEST_F(SavedModel, ReadingTheParametersAloneRefusesACorruptHeader) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("strata_saved_config_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "header.stratamodel").string();
  const auto write = [&](std::string_view bytes) {
    std::ofstream(path, std::ios::binary | std::ios::trunc) << bytes;
  };
  write(bytes());
  const Expected<AssessmentConfig> whole = ReadSavedModelConfig(path);
  ASSERT_TRUE(whole.ok()) << whole.error().message;
  EXPECT_FALSE(FirstDifference(*whole, model().config()).has_value());
  const std::size_t fields_end = bytes().find("num_threads") + 64;
  for (std::size_t cut = 0; cut < fields_end; cut += 7) {
    write(std::string_view(bytes()).substr(0, cut));
    const Expected<AssessmentConfig> truncated = ReadSavedModelConfig(path);
    ASSERT_FALSE(truncated.ok()) << "cut at " << cut;
    EXPECT_EQ(truncated.error().code, ErrorCode::kMapLoadFailed);
    EXPECT_THAT(truncated.error().message, HasSubstr("header.stratamodel"));
  }
  std::mt19937 rng(5);
  int refused = 0;
  for (std::size_t at = 0; at < fields_end; ++at) {
    std::string flipped = bytes();
    flipped[at] = static_cast<char>(flipped[at] ^ (1 << (rng() % 8)));
    write(flipped);
    const Expected<AssessmentConfig> read = ReadSavedModelConfig(path);
    if (!read.ok()) {
      ++refused;
      EXPECT_EQ(read.error().code, ErrorCode::kMapLoadFailed);
    }
  }
  EXPECT_GT(refused, 0);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace strata
