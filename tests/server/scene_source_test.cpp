// A scene named without a seed is the same map in strata-server (CreateMap without a seed,
// through SourceFromRequest and the registry's loader) as in strata-offline ("scene:NAME"
// through ParseMapSource and LoadMapSource, what its assess, plan and bench commands load).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>

#include "map_registry.hpp"
#include "map_service.hpp"
#include "strata/scenes/map_source.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata::server {
namespace {

PointCloud ServerCloud(const v1::CreateMapRequest& request) {
  Result<MapSource> source = SourceFromRequest(request, {});
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
  Result<MapSource> source = SourceFromRequest(request, {});
  ASSERT_TRUE(source.ok()) << source.error().message;
  ASSERT_TRUE(std::holds_alternative<SceneMapSource>(source.value()));
  EXPECT_EQ(std::get<SceneMapSource>(source.value()).seed, kDefaultSceneSeed);

  request.mutable_scene()->set_seed(9);
  source = SourceFromRequest(request, {});
  ASSERT_TRUE(source.ok()) << source.error().message;
  EXPECT_EQ(std::get<SceneMapSource>(source.value()).seed, 9u);
}

}  // namespace
}  // namespace strata::server
