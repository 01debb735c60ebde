// The one parser of "scene:NAME[:SEED][:size_m=M][:spacing_m=M]" and the one loader of "a file or a
// scene" that strata-server and strata-offline share (strata/scenes/map_source.hpp).
#include "strata/scenes/map_source.hpp"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <string>
#include <utility>

#include "strata/io/cloud_io.hpp"
#include "strata/scenes/scenes.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

TEST(ParseSceneSource, ReadsTheNameAndTheSeed) {
  Expected<SceneSource> scene = ParseSceneSource("scene:uneven_terrain:7");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->name, "uneven_terrain");
  EXPECT_EQ(scene->seed, 7u);

  scene = ParseSceneSource("scene:indoor_tables:4294967295");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->seed, 4294967295u);
}

TEST(ParseSceneSource, WithoutASeedTakesTheDefaultSeed) {
  const Expected<SceneSource> scene = ParseSceneSource("scene:two_level_ramp");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->name, "two_level_ramp");
  EXPECT_EQ(scene->seed, kDefaultSceneSeed);
  EXPECT_EQ(SceneSource{}.seed, kDefaultSceneSeed);
}

TEST(ParseSceneSource, ReadsSizeAndSpacingInAnyOrder) {
  Expected<SceneSource> scene = ParseSceneSource("scene:outdoor_site:3:size_m=400:spacing_m=0.2");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->name, "outdoor_site");
  EXPECT_EQ(scene->seed, 3u);
  EXPECT_EQ(scene->options.size_m, 400.0);
  EXPECT_EQ(scene->options.spacing_m, 0.2);

  scene = ParseSceneSource("scene:outdoor_site:spacing_m=0.25:size_m=1e3");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_EQ(scene->seed, kDefaultSceneSeed);
  EXPECT_EQ(scene->options.size_m, 1000.0);
  EXPECT_EQ(scene->options.spacing_m, 0.25);

  // Without options, none is set: the scene's defaults apply.
  scene = ParseSceneSource("scene:indoor_tables:2");
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  EXPECT_FALSE(scene->options.size_m || scene->options.spacing_m);
}

TEST(FormatSceneSource, ReadsBackAsTheSameScene) {
  SceneSource plain{"uneven_terrain", 7, {}};
  SceneSource sized{"outdoor_site", 4294967295u, {}};
  sized.options.size_m = 400.0;
  sized.options.spacing_m = 0.1 + 0.2;  // Not a short decimal: must still read back exactly.
  SceneSource spaced{"indoor_tables", 0, {}};
  spaced.options.spacing_m = 1.0e-3;
  for (const SceneSource& scene : {plain, sized, spaced}) {
    const std::string text = FormatSceneSource(scene);
    Expected<SceneSource> back = ParseSceneSource(text);
    ASSERT_TRUE(back.ok()) << text << ": " << back.error().message;
    EXPECT_EQ(back->name, scene.name) << text;
    EXPECT_EQ(back->seed, scene.seed) << text;
    EXPECT_EQ(back->options.size_m, scene.options.size_m) << text;
    EXPECT_EQ(back->options.spacing_m, scene.options.spacing_m) << text;
  }
  EXPECT_EQ(FormatSceneSource(plain), "scene:uneven_terrain:7");
}

TEST(ParseSceneSource, RefusesMalformedOptionsNamingThem) {
  const std::pair<std::string, std::string> cases[] = {
      {"scene:a:size_m=", "size_m must be a decimal number"},
      {"scene:a:size_m=big", "size_m must be a decimal number"},
      {"scene:a:spacing_m=inf", "spacing_m must be a decimal number"},
      {"scene:a:spacing_m=nan", "spacing_m must be a decimal number"},
      {"scene:a:size_m=+4", "size_m must be a decimal number"},
      {"scene:a:size_m=40m", "size_m must be a decimal number"},
      {"scene:a:size_m=40:size_m=50", "size_m is given twice"},
      {"scene:a:colour=red", "unknown option 'colour'"},
      {"scene:a:size_m=40:3", "the seed comes right after NAME"},
      {"scene:a:3:4", "the seed comes right after NAME"},
  };
  for (const auto& [text, why] : cases) {
    const Expected<SceneSource> scene = ParseSceneSource(text);
    ASSERT_FALSE(scene.ok()) << text;
    EXPECT_EQ(scene.error().code, ErrorCode::kInvalidInput) << text;
    EXPECT_THAT(scene.error().message, HasSubstr("'" + text + "'"));
    EXPECT_THAT(scene.error().message, HasSubstr(why));
  }
}

TEST(ParseSceneSource, RefusesMalformedTextNamingIt) {
  for (const std::string text :
       {"scene:", "scene::3", "scene:a:", "scene:a:-1", "scene:a:+1", "scene:a:1.5",
        "scene:a:4294967296", "scene:a:3x", "scene:a: 3", "two_level_ramp", "Scene:a"}) {
    const Expected<SceneSource> scene = ParseSceneSource(text);
    ASSERT_FALSE(scene.ok()) << text;
    EXPECT_EQ(scene.error().code, ErrorCode::kInvalidInput) << text;
    EXPECT_THAT(scene.error().message, HasSubstr("'" + text + "'"));
    EXPECT_THAT(scene.error().message, HasSubstr("scene:NAME[:SEED]"));
  }
}

TEST(ParseMapSource, SceneByPrefixElseAFile) {
  Expected<MapSource> source = ParseMapSource("scene:parking_garage:3");
  ASSERT_TRUE(source.ok());
  ASSERT_TRUE(std::holds_alternative<SceneSource>(*source));
  EXPECT_EQ(std::get<SceneSource>(*source).seed, 3u);

  for (const std::string path : {"maps/scene20.2.pcd", "scene.pcd", "/abs/scene:x.ply"}) {
    source = ParseMapSource(path);
    ASSERT_TRUE(source.ok()) << path;
    ASSERT_TRUE(std::holds_alternative<FileSource>(*source)) << path;
    EXPECT_EQ(std::get<FileSource>(*source).path, path);
  }
  EXPECT_FALSE(ParseMapSource("scene:a:b").ok());
}

TEST(LoadMapSource, GeneratesTheSceneWithItsSeed) {
  const Expected<LoadedCloud> loaded = LoadMapSource(SceneSource{"stairs_ramp_room", 5});
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  const PointCloud expected = GenerateScene("stairs_ramp_room", 5).value();
  EXPECT_EQ(loaded->raw_point_count, expected.size());
  EXPECT_EQ(loaded->dropped_nonfinite, 0u);
  EXPECT_TRUE(loaded->points == expected);
  EXPECT_FALSE(loaded->points == GenerateScene("stairs_ramp_room", 6).value());
}

TEST(LoadMapSource, GeneratesTheSceneWithItsOptions) {
  const Expected<LoadedCloud> loaded =
      LoadMapSource(ParseMapSource("scene:outdoor_site:2:size_m=50:spacing_m=0.3").value());
  ASSERT_TRUE(loaded.ok()) << loaded.error().message;
  EXPECT_TRUE(loaded->points ==
              GenerateScene("outdoor_site", 2, {.size_m = 50.0, .spacing_m = 0.3}).value());
  // A size for a scene without one fails as GenerateScene does.
  const Expected<LoadedCloud> sized =
      LoadMapSource(SceneSource{"stairs_ramp_room", 1, {.size_m = 50.0}});
  ASSERT_FALSE(sized.ok());
  EXPECT_EQ(sized.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(sized.error().message, HasSubstr("no size parameter"));
}

TEST(LoadMapSource, RefusesAPointCountAboveTheLimitBeforeGenerating) {
  CloudLoadLimits limits;
  limits.max_points = 1'000'000;
  const Expected<LoadedCloud> loaded =
      LoadMapSource(SceneSource{"outdoor_site", 1, {.size_m = 1000.0, .spacing_m = 0.02}}, limits);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(loaded.error().message, HasSubstr("above the limit of 1000000"));
}

TEST(LoadMapSource, AppliesTheLimitsToScenesToo) {
  CloudLoadLimits limits;
  limits.max_points = 1000;
  const Expected<LoadedCloud> loaded = LoadMapSource(SceneSource{"stairs_ramp_room"}, limits);
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kResourceExhausted);
}

TEST(LoadMapSource, FailuresNameTheProblem) {
  Expected<LoadedCloud> loaded = LoadMapSource(SceneSource{"no_such_scene"});
  ASSERT_FALSE(loaded.ok());
  EXPECT_EQ(loaded.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(loaded.error().message, HasSubstr("two_level_ramp"));  // Lists the known scenes.

  loaded = LoadMapSource(FileSource{"/no/such/dir/map.pcd"});
  ASSERT_FALSE(loaded.ok());
  EXPECT_THAT(loaded.error().message, HasSubstr("/no/such/dir/map.pcd"));
}

}  // namespace
}  // namespace strata
