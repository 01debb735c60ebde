// A scene named without a seed is the same map in strata-server (CreateMap without a seed,
// through SourceFromRequest and the registry's loader) as in strata-offline ("scene:NAME"
// through ParseMapSource and LoadMapSource, what its assess, plan and bench commands load); so
// is a scene with a size and a spacing. Bad options blame their request field.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <optional>
#include <string>

#include "maps/map_registry.hpp"
#include "rpc/map_service.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata::server {
namespace {

using ::testing::HasSubstr;

constexpr std::size_t kMaxPoints = CloudLoadLimits{}.max_points;

PointCloud ServerCloud(const v1::CreateMapRequest& request) {
  Result<MapSource> source = SourceFromRequest(request, {}, kMaxPoints);
  EXPECT_TRUE(source.ok()) << source.error().message;
  if (!source.ok()) return {};
  Expected<LoadedCloud> cloud = LoadMapSource(std::move(source).value(), CloudLoadLimits{});
  EXPECT_TRUE(cloud.ok()) << cloud.error().message;
  return cloud.ok() ? cloud->points : PointCloud{};
}

PointCloud OfflineCloud(const std::string& argument) {
  Expected<strata::MapSource> source = ParseMapSource(argument);
  EXPECT_TRUE(source.ok()) << source.error().message;
  if (!source.ok()) return {};
  Expected<LoadedCloud> cloud = ::strata::LoadMapSource(*source);
  EXPECT_TRUE(cloud.ok()) << cloud.error().message;
  return cloud.ok() ? cloud->points : PointCloud{};
}

TEST(SceneSourceTest, WithoutASeedServerAndOfflineToolLoadTheSameCloud) {
  // uneven_terrain is laid out by its seed, two_level_ramp only jittered by it.
  for (const std::string name : {"uneven_terrain", "two_level_ramp"}) {
    v1::CreateMapRequest request;
    request.mutable_scene()->set_name(name);
    ASSERT_FALSE(request.scene().has_seed());
    const PointCloud server = ServerCloud(request);
    ASSERT_FALSE(server.empty()) << name;
    EXPECT_TRUE(server == OfflineCloud("scene:" + name)) << name;
    EXPECT_TRUE(server == GenerateScene(name, kDefaultSceneSeed).value()) << name;

    // An explicit seed is honoured on both sides, 0 included.
    request.mutable_scene()->set_seed(0);
    const PointCloud seed0 = ServerCloud(request);
    EXPECT_FALSE(seed0 == server) << name << ": seed 0 must differ from the default seed";
    EXPECT_TRUE(seed0 == OfflineCloud("scene:" + name + ":0")) << name;
  }
}

TEST(SceneSourceTest, TheRequestsSeedOrTheDefaultIsWhatTheMapRecords) {
  v1::CreateMapRequest request;
  request.mutable_scene()->set_name("stairs_ramp_room");
  Result<MapSource> source = SourceFromRequest(request, {}, kMaxPoints);
  ASSERT_TRUE(source.ok()) << source.error().message;
  ASSERT_TRUE(std::holds_alternative<SceneMapSource>(source.value()));
  const SceneMapSource& scene = std::get<SceneMapSource>(source.value());
  EXPECT_EQ(scene.seed, kDefaultSceneSeed);
  // The scene's own spacing, filled in; no size for a scene without one.
  EXPECT_EQ(scene.options.spacing_m, 0.05);
  EXPECT_FALSE(scene.options.size_m.has_value());

  request.mutable_scene()->set_seed(9);
  source = SourceFromRequest(request, {}, kMaxPoints);
  ASSERT_TRUE(source.ok()) << source.error().message;
  EXPECT_EQ(std::get<SceneMapSource>(source.value()).seed, 9u);
}

TEST(SceneSourceTest, SizeAndSpacingAreTheOfflineToolsToo) {
  v1::CreateMapRequest request;
  request.mutable_scene()->set_name("outdoor_site");
  request.mutable_scene()->set_size_m(50);
  request.mutable_scene()->set_spacing_m(0.3);
  const PointCloud server = ServerCloud(request);
  ASSERT_FALSE(server.empty());
  EXPECT_TRUE(server == OfflineCloud("scene:outdoor_site:size_m=50:spacing_m=0.3"));
  // Without them, the scene's defaults on both sides.
  request.mutable_scene()->clear_size_m();
  request.mutable_scene()->clear_spacing_m();
  const Result<MapSource> source = SourceFromRequest(request, {}, kMaxPoints);
  ASSERT_TRUE(source.ok()) << source.error().message;
  const SceneOptions& options = std::get<SceneMapSource>(source.value()).options;
  EXPECT_EQ(options.size_m, 100.0);
  EXPECT_EQ(options.spacing_m, 0.1);
}

TEST(SceneSourceTest, BadOptionsBlameTheirFieldAndTooManyPointsAreRefusedUpFront) {
  const auto refused = [](const std::string& name, std::optional<double> size,
                          std::optional<double> spacing, std::size_t max_points) {
    v1::CreateMapRequest request;
    request.mutable_scene()->set_name(name);
    if (size) request.mutable_scene()->set_size_m(*size);
    if (spacing) request.mutable_scene()->set_spacing_m(*spacing);
    Result<MapSource> source = SourceFromRequest(request, {}, max_points);
    EXPECT_FALSE(source.ok()) << name;
    return source.ok() ? ServiceError{} : std::move(source).error();
  };
  ServiceError error = refused("two_level_ramp", 40.0, {}, kMaxPoints);
  EXPECT_EQ(error.code, ServiceError::Code(ErrorCode::kInvalidInput));
  ASSERT_EQ(error.field_violations.size(), 1u);
  EXPECT_EQ(error.field_violations[0].field, "scene.size_m");
  EXPECT_THAT(error.message, HasSubstr("outdoor_site"));  // The scene that takes a size.

  error = refused("outdoor_site", 20.0, {}, kMaxPoints);
  ASSERT_EQ(error.field_violations.size(), 1u);
  EXPECT_EQ(error.field_violations[0].field, "scene.size_m");

  error = refused("outdoor_site", {}, 0.0, kMaxPoints);
  ASSERT_EQ(error.field_violations.size(), 1u);
  EXPECT_EQ(error.field_violations[0].field, "scene.spacing_m");

  // The server's --max-points, before the scene is generated.
  error = refused("outdoor_site", {}, {}, 100'000);
  EXPECT_EQ(error.code, ServiceError::Code(ErrorCode::kResourceExhausted));
  ASSERT_EQ(error.field_violations.size(), 1u);
  EXPECT_EQ(error.field_violations[0].field, "scene.spacing_m");
  EXPECT_THAT(error.message, HasSubstr("above the limit of 100000"));
}

}  // namespace
}  // namespace strata::server
