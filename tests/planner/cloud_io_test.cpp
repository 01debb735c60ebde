#include "strata/io/cloud_io.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>
#include <string>
#include <string_view>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

// The round trips write their fixtures with PCL's own writers.
#if !__has_include(<pcl/io/pcd_io.h>)
#error \
    "cloud_io_test needs PCL's headers: in tests/planner/CMakeLists.txt add \
target_include_directories(cloud_io_test PRIVATE ${PCL_INCLUDE_DIRS})"
#endif
#include <octomap/ColorOcTree.h>
#include <octomap/OcTree.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

namespace strata {
namespace {

namespace fs = std::filesystem;
using ::testing::AnyOf;
using ::testing::HasSubstr;
using ::testing::StartsWith;

constexpr float kNan = std::numeric_limits<float>::quiet_NaN();
constexpr float kInf = std::numeric_limits<float>::infinity();

template <typename... Values>
std::string Bytes(const Values&... values) {
  std::string out;
  (out.append(reinterpret_cast<const char*>(&values), sizeof(values)), ...);
  return out;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), {});
}

pcl::PointCloud<pcl::PointXYZI> RandomCloud(int count, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> coordinate(-50.0f, 50.0f);
  pcl::PointCloud<pcl::PointXYZI> cloud;
  for (int i = 0; i < count; ++i) {
    pcl::PointXYZI p;
    p.x = coordinate(rng);
    p.y = coordinate(rng);
    p.z = coordinate(rng);
    p.intensity = static_cast<float>(i);
    cloud.push_back(p);
  }
  return cloud;
}

template <typename PclCloud>
void ExpectSamePoints(const PointCloud& got, const PclCloud& want, float tolerance) {
  ASSERT_EQ(got.size(), want.size());
  for (std::size_t i = 0; i < got.size(); ++i) {
    EXPECT_NEAR(got[i].x(), want[i].x, tolerance) << "point " << i;
    EXPECT_NEAR(got[i].y(), want[i].y, tolerance) << "point " << i;
    EXPECT_NEAR(got[i].z(), want[i].z, tolerance) << "point " << i;
  }
}

std::vector<Eigen::Vector3f> Sorted(std::vector<Eigen::Vector3f> points) {
  std::sort(points.begin(), points.end(), [](const auto& a, const auto& b) {
    return std::lexicographical_compare(a.data(), a.data() + 3, b.data(), b.data() + 3);
  });
  return points;
}

void ExpectSameSet(const PointCloud& got, const std::vector<Eigen::Vector3f>& want) {
  const auto a = Sorted(got), b = Sorted(want);
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_TRUE(a[i].isApprox(b[i], 1e-5f)) << a[i].transpose() << " vs " << b[i].transpose();
  }
}

// A header like the ones real exporters write (and the shared maps have).
std::string PcdHeader(const std::string& dimensions, std::uint64_t points,
                      const std::string& data) {
  return "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z intensity\n"
         "SIZE 4 4 4 4\nTYPE F F F F\nCOUNT 1 1 1 1\n" +
         dimensions + "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " + std::to_string(points) + "\nDATA " +
         data + "\n";
}

class CloudIoTest : public ::testing::Test {
 protected:
  void SetUp() override {
    const std::string name = ::testing::UnitTest::GetInstance()->current_test_info()->name();
    dir_ = fs::path(::testing::TempDir()) /
           ("strata_cloud_io_" + name + "_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    std::error_code ignored;
    fs::remove_all(dir_, ignored);
  }

  std::string PathFor(const std::string& name) const { return (dir_ / name).string(); }

  std::string Write(const std::string& name, std::string_view bytes) const {
    const std::string path = PathFor(name);
    std::ofstream(path, std::ios::binary).write(bytes.data(), bytes.size());
    return path;
  }

  static LoadedCloud LoadOk(const std::string& path, const CloudLoadLimits& limits = {}) {
    Expected<LoadedCloud> cloud = LoadPointCloud(path, limits);
    EXPECT_TRUE(cloud.ok()) << (cloud.ok() ? "" : cloud.error().message);
    return cloud.ok() ? *cloud : LoadedCloud{};
  }

  static void ExpectError(const std::string& path, ErrorCode code, const std::string& phrase,
                          const CloudLoadLimits& limits = {}) {
    Expected<LoadedCloud> cloud = LoadPointCloud(path, limits);
    ASSERT_FALSE(cloud.ok()) << path << " loaded " << cloud->points.size() << " points";
    EXPECT_EQ(ErrorCodeName(cloud.error().code), std::string(ErrorCodeName(code)))
        << cloud.error().message;
    EXPECT_THAT(cloud.error().message, StartsWith(path));
    EXPECT_THAT(cloud.error().message, HasSubstr(phrase));
  }

  // An OcTree with a few occupied voxels far apart (so nothing is pruned) and one free voxel.
  static octomap::OcTree SmallTree(std::vector<Eigen::Vector3f>* occupied_centres) {
    octomap::OcTree tree(0.1);
    const octomap::point3d points[] = {
        {1.02f, 2.04f, 0.33f}, {-3.0f, 0.5f, 1.2f}, {10.0f, -7.3f, 2.2f}, {0.0f, 0.0f, -4.5f}};
    for (const auto& p : points) {
      tree.updateNode(p, true);
      const octomap::point3d c = tree.keyToCoord(tree.coordToKey(p));
      occupied_centres->emplace_back(c.x(), c.y(), c.z());
    }
    tree.updateNode(octomap::point3d(5.0f, 5.0f, 5.0f), false);
    tree.updateInnerOccupancy();
    return tree;
  }

  fs::path dir_;
};

TEST_F(CloudIoTest, PcdRoundTripsInEveryEncoding) {
  const auto cloud = RandomCloud(500, 1);
  ASSERT_EQ(pcl::io::savePCDFileASCII(PathFor("a.pcd"), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinary(PathFor("b.pcd"), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(PathFor("c.pcd"), cloud), 0);

  const LoadedCloud ascii = LoadOk(PathFor("a.pcd"));
  ExpectSamePoints(ascii.points, cloud, 1e-4f);  // ASCII keeps 8 significant digits.
  EXPECT_EQ(ascii.raw_point_count, 500u);
  EXPECT_EQ(ascii.dropped_nonfinite, 0u);
  ExpectSamePoints(LoadOk(PathFor("b.pcd")).points, cloud, 0.0f);
  ExpectSamePoints(LoadOk(PathFor("c.pcd")).points, cloud, 0.0f);
}

TEST_F(CloudIoTest, PcdWithDoubleCoordinatesAndLeadingFieldLoads) {
  const std::string header =
      "VERSION 0.7\nFIELDS intensity x y z\nSIZE 4 8 8 8\nTYPE F F F F\nCOUNT 1 1 1 1\n"
      "WIDTH 2\nHEIGHT 1\nPOINTS 2\nDATA binary\n";
  const std::string path =
      Write("f8.pcd", header + Bytes(7.0f, 1.25, -2.5, 3.75) + Bytes(8.0f, 1.0e4, 0.125, -99.0));
  ExpectSameSet(LoadOk(path).points, {{1.25f, -2.5f, 3.75f}, {1.0e4f, 0.125f, -99.0f}});
}

TEST_F(CloudIoTest, PlyRoundTripsAsciiAndBinaryIgnoringColour) {
  pcl::PointCloud<pcl::PointXYZRGB> cloud;
  for (const auto& p : RandomCloud(300, 2)) {
    pcl::PointXYZRGB q(static_cast<std::uint8_t>(std::clamp(p.intensity, 0.0f, 255.0f)), 20, 30);
    q.x = p.x;
    q.y = p.y;
    q.z = p.z;
    cloud.push_back(q);
  }
  ASSERT_EQ(pcl::io::savePLYFile(PathFor("a.ply"), cloud, false), 0);
  ASSERT_EQ(pcl::io::savePLYFile(PathFor("b.ply"), cloud, true), 0);
  ExpectSamePoints(LoadOk(PathFor("a.ply")).points, cloud, 1e-4f);
  ExpectSamePoints(LoadOk(PathFor("b.ply")).points, cloud, 0.0f);
}

TEST_F(CloudIoTest, OctomapRoundTripsGiveOccupiedVoxelCentres) {
  std::vector<Eigen::Vector3f> occupied;
  octomap::OcTree tree = SmallTree(&occupied);
  ASSERT_TRUE(tree.write(PathFor("map.ot")));
  ASSERT_TRUE(tree.writeBinary(PathFor("map.bt")));

  const LoadedCloud text = LoadOk(PathFor("map.ot"));
  ExpectSameSet(text.points, occupied);
  ExpectSameSet(LoadOk(PathFor("map.bt")).points, occupied);
  EXPECT_EQ(text.raw_point_count, occupied.size());
}

TEST_F(CloudIoTest, OctomapPrunedBlockBecomesOneVoxelPerCell) {
  // Eight voxels filling an aligned 2x2x2 block are pruned into one leaf one level up; its
  // centre alone would sit between the voxels, so each voxel comes back instead.
  octomap::OcTree tree(0.1);
  octomap::OcTreeKey base = tree.coordToKey(octomap::point3d(1.0f, 1.0f, 1.0f));
  for (auto& k : base.k) k &= ~1u;
  std::vector<Eigen::Vector3f> voxels;
  for (unsigned i = 0; i < 8; ++i) {
    const octomap::OcTreeKey key(base[0] + (i & 1), base[1] + ((i >> 1) & 1), base[2] + (i >> 2));
    tree.updateNode(key, true);
    const octomap::point3d c = tree.keyToCoord(key);
    voxels.emplace_back(c.x(), c.y(), c.z());
  }
  tree.updateInnerOccupancy();
  ASSERT_TRUE(tree.writeBinary(PathFor("block.bt")));
  ASSERT_EQ(tree.getNumLeafNodes(), 1u) << "the block should have been pruned into one leaf";
  ASSERT_TRUE(tree.write(PathFor("block.ot")));

  ExpectSameSet(LoadOk(PathFor("block.bt")).points, voxels);
  ExpectSameSet(LoadOk(PathFor("block.ot")).points, voxels);
}

TEST_F(CloudIoTest, AnOctomapBlockComesBackAsItsFacesOnly) {
  // A solid, aligned 8x8x8 block is pruned into one leaf; only its faces can be ground or an
  // obstacle's surface, so its 296 face voxels come back and none of the 216 inside.
  octomap::OcTree tree(0.1);
  octomap::OcTreeKey base = tree.coordToKey(octomap::point3d(1.0f, 1.0f, 1.0f));
  for (auto& k : base.k) k &= ~7u;
  std::vector<Eigen::Vector3f> faces;
  for (unsigned i = 0; i < 8; ++i) {
    for (unsigned j = 0; j < 8; ++j) {
      for (unsigned k = 0; k < 8; ++k) {
        const octomap::OcTreeKey key(base[0] + i, base[1] + j, base[2] + k);
        tree.updateNode(key, true);
        const bool inside = i % 7 != 0 && j % 7 != 0 && k % 7 != 0;
        if (inside) continue;
        const octomap::point3d c = tree.keyToCoord(key);
        faces.emplace_back(c.x(), c.y(), c.z());
      }
    }
  }
  tree.updateInnerOccupancy();
  ASSERT_EQ(tree.getNumLeafNodes(), 1u) << "the block should have been pruned into one leaf";
  ASSERT_TRUE(tree.writeBinary(PathFor("cube.bt")));
  ASSERT_EQ(faces.size(), 296u);
  ExpectSameSet(LoadOk(PathFor("cube.bt")).points, faces);
}

TEST_F(CloudIoTest, ATinyOctomapNamingMillionsOfVoxelsIsRefusedAtOnce) {
  // 16 bytes of tree: inner nodes down to depth 7, then two occupied leaves at depth 8, each a
  // solid block of 256^3 voxels (33.5 million inside; 780,304 on their faces). It used to be
  // expanded voxel by voxel and held an assessment for minutes.
  std::string tree;
  for (int depth = 0; depth < 7; ++depth) tree += std::string("\x03\x00", 2);  // Child 0: inner.
  tree += std::string("\x0a\x00", 2);  // Children 0 and 1: occupied leaves.
  const std::string file =
      "# Octomap OcTree binary file\nid OcTree\nsize 10\nres 0.1\ndata\n" + tree;
  ExpectError(Write("tiny.bt", file), ErrorCode::kMapLoadFailed, "per byte of file");
}

TEST_F(CloudIoTest, ExtensionIsCaseInsensitive) {
  ASSERT_EQ(pcl::io::savePCDFileBinary(PathFor("UPPER.PCD"), RandomCloud(5, 3)), 0);
  EXPECT_EQ(LoadOk(PathFor("UPPER.PCD")).points.size(), 5u);
}

TEST_F(CloudIoTest, PcdWithZeroWidthAndHeightLoads) {
  const std::string binary = Write(
      "binary.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 3, "binary") + Bytes(1.0f, 2.0f, 3.0f, 0.5f) +
                        Bytes(-4.0f, 5.5f, 6.0f, 0.5f) + Bytes(7.0f, 8.0f, -9.25f, 0.5f));
  const std::string ascii = Write("ascii.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 3, "ascii") +
                                                   "1 2 3 0.5\n-4 5.5 6 0.5\n7 8 -9.25 0.5\n");
  const std::vector<Eigen::Vector3f> want = {{1, 2, 3}, {-4, 5.5f, 6}, {7, 8, -9.25f}};
  ExpectSameSet(LoadOk(binary).points, want);
  ExpectSameSet(LoadOk(ascii).points, want);
}

TEST_F(CloudIoTest, NonFinitePointsAreDroppedAndCounted) {
  const std::string ascii = Write("nan.pcd", PcdHeader("WIDTH 4\nHEIGHT 1", 4, "ascii") +
                                                 "1 2 3 0\nnan 2 3 0\n4 nan 6 0\n7 8 9 0\n");
  const LoadedCloud a = LoadOk(ascii);
  EXPECT_EQ(a.raw_point_count, 4u);
  EXPECT_EQ(a.dropped_nonfinite, 2u);
  ExpectSameSet(a.points, {{1, 2, 3}, {7, 8, 9}});

  const std::string binary =
      Write("inf.pcd", PcdHeader("WIDTH 3\nHEIGHT 1", 3, "binary") + Bytes(kInf, 0.f, 0.f, 0.f) +
                           Bytes(1.f, 1.f, 1.f, kNan) + Bytes(0.f, 0.f, -kInf, 0.f));
  const LoadedCloud b = LoadOk(binary);
  EXPECT_EQ(b.raw_point_count, 3u);
  EXPECT_EQ(b.dropped_nonfinite, 2u);  // A NaN intensity does not matter.
  ExpectSameSet(b.points, {{1, 1, 1}});

  ExpectError(Write("allnan.pcd", PcdHeader("WIDTH 1\nHEIGHT 1", 1, "ascii") + "nan 0 0 0\n"),
              ErrorCode::kMapLoadFailed, "contains no finite points");
}

TEST_F(CloudIoTest, SanitizeCloudDropsNonFiniteAndEnforcesLimits) {
  Expected<LoadedCloud> ok = SanitizeCloud({{1, 2, 3}, {kNan, 0, 0}, {0, kInf, 0}, {4, 5, 6}});
  ASSERT_TRUE(ok.ok()) << ok.error().message;
  EXPECT_EQ(ok->raw_point_count, 4u);
  EXPECT_EQ(ok->dropped_nonfinite, 2u);
  ExpectSameSet(ok->points, {{1, 2, 3}, {4, 5, 6}});

  Expected<LoadedCloud> far = SanitizeCloud({{0, 0, 0}, {0, 0, 0}, {1e30f, 0, 0}});
  ASSERT_FALSE(far.ok());
  EXPECT_EQ(far.error().code, ErrorCode::kInvalidInput);
  EXPECT_THAT(far.error().message, HasSubstr("point 2 at (1e+30, 0, 0) m"));
  EXPECT_THAT(far.error().message, HasSubstr("100000 m coordinate limit"));

  CloudLoadLimits two_points;
  two_points.max_points = 2;
  Expected<LoadedCloud> many = SanitizeCloud({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}}, two_points);
  ASSERT_FALSE(many.ok());
  EXPECT_EQ(many.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(many.error().message, HasSubstr("3 points"));

  Expected<LoadedCloud> none = SanitizeCloud({{kNan, kNan, kNan}});
  ASSERT_FALSE(none.ok());
  EXPECT_THAT(none.error().message, HasSubstr("no finite points"));

  CloudLoadLimits nan_limit;
  nan_limit.max_abs_coordinate_m = std::nan("");
  Expected<LoadedCloud> bad_config = SanitizeCloud({{0, 0, 0}}, nan_limit);
  ASSERT_FALSE(bad_config.ok());
  EXPECT_EQ(bad_config.error().code, ErrorCode::kInvalidConfig);
  EXPECT_THAT(bad_config.error().message, HasSubstr("max_abs_coordinate_m"));
}

TEST_F(CloudIoTest, CoordinateBeyondLimitNamesPointAndValue) {
  std::string body;
  for (int i = 0; i < 20; ++i) body += (i == 17 ? "1e30 0 0 0\n" : "1 2 3 0\n");
  const std::string path = Write("far.pcd", PcdHeader("WIDTH 20\nHEIGHT 1", 20, "ascii") + body);
  ExpectError(path, ErrorCode::kInvalidInput, "point 17 at (1e+30, 0, 0) m");
  ExpectError(path, ErrorCode::kInvalidInput, "beyond the 100000 m coordinate limit");
}

TEST_F(CloudIoTest, FileSystemProblemsAreNamed) {
  ExpectError(PathFor("missing.pcd"), ErrorCode::kMapLoadFailed, "not found");
  fs::create_directories(PathFor("dir.pcd"));
  ExpectError(PathFor("dir.pcd"), ErrorCode::kMapLoadFailed, "is a directory");
  ExpectError(Write("empty.pcd", ""), ErrorCode::kMapLoadFailed, "empty (0 bytes)");
  ExpectError(Write("cloud.xyz", "1 2 3\n"), ErrorCode::kMapLoadFailed,
              "supported: .pcd, .ply, .bt, .ot");
  ExpectError(Write("noext", "1 2 3\n"), ErrorCode::kMapLoadFailed, "unsupported extension");
}

TEST_F(CloudIoTest, MalformedPcdIsRejectedWithReason) {
  const std::string record = Bytes(1.f, 2.f, 3.f, 4.f);
  ExpectError(Write("short.pcd", PcdHeader("WIDTH 30\nHEIGHT 1", 30, "binary") + record + record),
              ErrorCode::kMapLoadFailed,
              "header promises 30 points of 16 bytes (480 bytes) but the body holds 32 bytes");
  ExpectError(Write("short_ascii.pcd", PcdHeader("WIDTH 5\nHEIGHT 1", 5, "ascii") + "1 2 3 4\n"),
              ErrorCode::kMapLoadFailed, "promises 5 points but the body holds 1 lines");
  ExpectError(Write("ragged.pcd", PcdHeader("WIDTH 2\nHEIGHT 1", 2, "ascii") + "1 2 3 4\n1 2\n"),
              ErrorCode::kMapLoadFailed, "data line 2 has 2 values but the fields need 4");
  ExpectError(Write("noxyz.pcd",
                    "VERSION 0.7\nFIELDS a b c\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\n"
                    "HEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n"),
              ErrorCode::kMapLoadFailed, "has no x, y and z fields (it has: a, b, c)");
  ExpectError(Write("dims.pcd", PcdHeader("WIDTH 2\nHEIGHT 2", 3, "ascii")),
              ErrorCode::kMapLoadFailed, "WIDTH 2 x HEIGHT 2 but POINTS 3");
  ExpectError(Write("encoding.pcd", PcdHeader("WIDTH 1\nHEIGHT 1", 1, "zip") + record),
              ErrorCode::kMapLoadFailed, "expected ascii, binary or binary_compressed");
  ExpectError(Write("layout.pcd",
                    "FIELDS x y z\nSIZE 4 4 3\nTYPE F F F\nCOUNT 1 1 1\nPOINTS 1\nDATA binary\n" +
                        std::string(12, '\0')),
              ErrorCode::kMapLoadFailed, "disagree");
  // Found by the pcd fuzzer: POINTS between two COUNT lines, the first -1, made PCL allocate
  // POINTS records of the first COUNT's size (8 GiB) before the second replaced it.
  ExpectError(Write("recount.pcd",
                    "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT -1 1 1\nPOINTS 2\n"
                    "COUNT 1 1 1\nDATA ascii\n1 2 3\n4 5 6\n"),
              ErrorCode::kMapLoadFailed, "repeats COUNT; a PCD header has each field once");
}

TEST_F(CloudIoTest, CorruptCompressedPcdIsRejected) {
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(PathFor("good.pcd"), RandomCloud(200, 4)), 0);
  const std::string good = ReadFile(PathFor("good.pcd"));
  const std::size_t body = good.find("DATA binary_compressed\n") + 23;
  ASSERT_LT(body, good.size());

  std::string garbled = good;  // 0xFF control bytes are back-references before the output start.
  std::fill(garbled.begin() + body + 8, garbled.end(), '\xff');
  ExpectError(Write("garbled.pcd", garbled), ErrorCode::kMapLoadFailed, "corrupt compressed block");

  ExpectError(Write("cut.pcd", good.substr(0, body + 40)), ErrorCode::kMapLoadFailed,
              "runs past the end");
  ExpectError(Write("prefix.pcd", good.substr(0, body + 5)), ErrorCode::kMapLoadFailed,
              "shorter than its 8-byte size prefix");

  std::string resized = good;  // Claims to unpack to more than the header's points need.
  resized[body + 4] = '\x01';
  resized[body + 7] = '\x7f';
  ExpectError(Write("resized.pcd", resized), ErrorCode::kMapLoadFailed,
              "compressed block says it unpacks to");
}

TEST_F(CloudIoTest, MalformedPlyIsRejectedWithReason) {
  ExpectError(Write("noxyz.ply",
                    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float a\nproperty float b\n"
                    "end_header\n1 2\n3 4\n"),
              ErrorCode::kMapLoadFailed, "lacks x, y and z");
  ExpectError(Write("novertex.ply", "ply\nformat ascii 1.0\nelement face 0\nend_header\n"),
              ErrorCode::kMapLoadFailed, "no 'element vertex'");
  const std::string header =
      "ply\nformat binary_little_endian 1.0\nelement vertex 10\nproperty float x\n"
      "property float y\nproperty float z\nend_header\n";
  ExpectError(Write("short.ply", header + Bytes(1.f, 2.f, 3.f)), ErrorCode::kMapLoadFailed,
              "truncated");
  ExpectError(Write("noend.ply", "ply\nformat ascii 1.0\nelement vertex 1\n"),
              ErrorCode::kMapLoadFailed, "no end_header");
  // A value missing from the last ASCII line passes the size check; PCL must catch it.
  ExpectError(Write("ragged.ply",
                    "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\n"
                    "property float z\nend_header\n1 2 3\n4 55555\n"),
              ErrorCode::kMapLoadFailed, "PCL could not parse");
}

// Both headers abort the whole process inside Debian's PCL (its assertions are on) unless
// they are refused before PCL reads the file.
TEST_F(CloudIoTest, PlyHeadersThatTripPclAssertionsAreRefused) {
  const std::string vertices =
      "property float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 1 1\n";
  ExpectError(Write("indented.ply",
                    "ply\nformat ascii 1.0\n obj_info num_cols 2\n"
                    "element vertex 2\n" +
                        vertices),
              ErrorCode::kMapLoadFailed, "starts with whitespace");
  ExpectError(Write("tab.ply",
                    "ply\nformat ascii 1.0\n\tobj_info num_cols 2\n"
                    "element vertex 2\n" +
                        vertices),
              ErrorCode::kMapLoadFailed, "starts with whitespace");
  // The ply fuzzer's find (scripts/fuzz.sh, after 3.1 M inputs): a carriage return before
  // the keyword, which PCL skips as whitespace as it does a space.
  ExpectError(Write("carriage_return.ply",
                    "ply\nformat ascii 1.0\n\robj_info\n"
                    "element vertex 2\n" +
                        vertices),
              ErrorCode::kMapLoadFailed, "starts with whitespace");
  ExpectError(Write("small_grid.ply",
                    "ply\nformat ascii 1.0\nobj_info num_cols 1\n"
                    "obj_info num_rows 1\nelement vertex 2\n" +
                        vertices),
              ErrorCode::kMapLoadFailed, "must equal the 2 vertices");
  ExpectError(Write("cols_only.ply",
                    "ply\nformat ascii 1.0\nobj_info num_cols 1\n"
                    "element vertex 2\n" +
                        vertices),
              ErrorCode::kMapLoadFailed, "give both or neither");
  // A grid that holds the vertices exactly is an organised cloud and loads.
  EXPECT_EQ(LoadOk(Write("organised.ply",
                         "ply\nformat ascii 1.0\nobj_info num_cols 2\n"
                         "obj_info num_rows 1\nelement vertex 2\n" +
                             vertices))
                .points.size(),
            2u);
}

TEST_F(CloudIoTest, NonCloudFilesAreRejected) {
  std::mt19937 rng(5);
  std::string noise(4096, '\0');
  for (char& c : noise) c = static_cast<char>(rng());
  const std::string text = "Dear diary,\ntoday I wrote a point-cloud loader.\n";
  for (const char* extension : {".pcd", ".ply", ".bt", ".ot"}) {
    SCOPED_TRACE(extension);
    const std::string random_path = Write(std::string("noise") + extension, noise);
    const std::string text_path = Write(std::string("text") + extension, text);
    for (const std::string& path : {random_path, text_path}) {
      Expected<LoadedCloud> cloud = LoadPointCloud(path);
      ASSERT_FALSE(cloud.ok());
      EXPECT_EQ(cloud.error().code, ErrorCode::kMapLoadFailed);
      EXPECT_THAT(cloud.error().message, StartsWith(path));
      EXPECT_THAT(cloud.error().message,
                  AnyOf(HasSubstr("is this a PCD file?"), HasSubstr("is this a PLY file?"),
                        HasSubstr("is this an OctoMap")));
    }
  }
}

TEST_F(CloudIoTest, HugeDeclaredCountsFailWithoutAllocating) {
  const std::string record = Bytes(1.f, 2.f, 3.f, 4.f);
  ExpectError(
      Write("trillion.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 1'000'000'000'000, "binary") + record),
      ErrorCode::kResourceExhausted, "1000000000000 points");
  ExpectError(Write("trillion.ply",
                    "ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\n"
                    "property float x\nproperty float y\nproperty float z\nend_header\n" +
                        record),
              ErrorCode::kResourceExhausted, "1000000000000 vertices");

  // With the point limit lifted, 4e9 points of 16 bytes (64 GB) must still be refused from the
  // file size alone: had PCL allocated first, this would be an out-of-memory error instead.
  CloudLoadLimits unlimited;
  unlimited.max_points = std::numeric_limits<std::size_t>::max();
  ExpectError(Write("binary.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 4'000'000'000, "binary") + record),
              ErrorCode::kMapLoadFailed, "but the body holds 16 bytes (truncated file?)",
              unlimited);
  ExpectError(
      Write("ascii.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 4'000'000'000, "ascii") + "1 2 3 4\n"),
      ErrorCode::kMapLoadFailed, "holds 1 lines of values (truncated file?)", unlimited);
  ExpectError(
      Write("compressed.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 4'000'000'000, "binary_compressed") +
                                  Bytes(std::uint32_t{4}, std::uint32_t{4'000'000'000u}) + record),
      ErrorCode::kMapLoadFailed, "compressed block says it unpacks to", unlimited);
}

TEST_F(CloudIoTest, LimitsOnFileSizeAndPointCountAreEnforced) {
  ASSERT_EQ(pcl::io::savePCDFileBinary(PathFor("ten.pcd"), RandomCloud(10, 6)), 0);
  CloudLoadLimits small_file;
  small_file.max_file_bytes = 100;
  ExpectError(PathFor("ten.pcd"), ErrorCode::kResourceExhausted, "limit of 100", small_file);
  CloudLoadLimits few_points;
  few_points.max_points = 9;
  ExpectError(PathFor("ten.pcd"), ErrorCode::kResourceExhausted, "declares 10 points", few_points);
  EXPECT_EQ(LoadOk(PathFor("ten.pcd")).points.size(), 10u);
}

TEST_F(CloudIoTest, MalformedOctomapIsRejectedWithReason) {
  std::vector<Eigen::Vector3f> occupied;
  octomap::OcTree tree = SmallTree(&occupied);
  ASSERT_TRUE(tree.write(PathFor("good.ot")));
  ASSERT_TRUE(tree.writeBinary(PathFor("good.bt")));
  const std::string ot = ReadFile(PathFor("good.ot")), bt = ReadFile(PathFor("good.bt"));

  ExpectError(Write("cut.bt", bt.substr(0, bt.size() - 3)), ErrorCode::kMapLoadFailed,
              "ends early (truncated file?)");
  ExpectError(Write("cut.ot", ot.substr(0, ot.size() - 3)), ErrorCode::kMapLoadFailed,
              "ends early (truncated file?)");
  // Every child an inner node, forever: OctoMap itself would recurse until it ran out.
  const std::size_t bt_data = bt.find("data\n") + 5;
  ExpectError(Write("deep.bt", bt.substr(0, bt_data) + std::string(4096, '\xff')),
              ErrorCode::kMapLoadFailed, "deeper than 16 levels");
  std::string extra = bt;
  extra.replace(extra.find("size "), 5, "size 1");  // Prepends a digit: a wrong node count.
  ExpectError(Write("count.bt", extra), ErrorCode::kMapLoadFailed, "nodes but the data holds");
  ExpectError(Write("swapped.ot", bt), ErrorCode::kMapLoadFailed, "rename it to .bt");
  ExpectError(Write("swapped.bt", ot), ErrorCode::kMapLoadFailed, "rename it to .ot");
  ExpectError(Write("nodata.bt", "# Octomap OcTree binary file\nid OcTree\nsize 1\nres 0.1\n"),
              ErrorCode::kMapLoadFailed, "no 'data' line");
  ExpectError(Write("badres.bt",
                    "# Octomap OcTree binary file\nid OcTree\nsize 1\nres nan\n"
                    "data\n\x02\x00"),
              ErrorCode::kMapLoadFailed, "resolution > 0");

  octomap::ColorOcTree colour(0.1);
  colour.updateNode(octomap::point3d(1.0f, 1.0f, 1.0f), true);
  ASSERT_TRUE(colour.write(PathFor("colour.ot")));
  ExpectError(PathFor("colour.ot"), ErrorCode::kMapLoadFailed, "'ColorOcTree', not an OcTree");
}

// Seeded random truncations and byte flips of valid files of every format: each load either
// succeeds with sane points or fails with a message naming the file, and never crashes.
TEST_F(CloudIoTest, MutatedFilesNeverCrash) {
  const auto cloud = RandomCloud(64, 7);
  ASSERT_EQ(pcl::io::savePCDFileASCII(PathFor("seed_a.pcd"), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinary(PathFor("seed_b.pcd"), cloud), 0);
  ASSERT_EQ(pcl::io::savePCDFileBinaryCompressed(PathFor("seed_c.pcd"), cloud), 0);
  ASSERT_EQ(pcl::io::savePLYFile(PathFor("seed_a.ply"), cloud, false), 0);
  ASSERT_EQ(pcl::io::savePLYFile(PathFor("seed_b.ply"), cloud, true), 0);
  std::vector<Eigen::Vector3f> occupied;
  octomap::OcTree tree = SmallTree(&occupied);
  ASSERT_TRUE(tree.write(PathFor("seed.ot")));
  ASSERT_TRUE(tree.writeBinary(PathFor("seed.bt")));

  std::mt19937 rng(8);
  int failures = 0, successes = 0;
  for (const char* seed : {"seed_a.pcd", "seed_b.pcd", "seed_c.pcd", "seed_a.ply", "seed_b.ply",
                           "seed.ot", "seed.bt"}) {
    const std::string good = ReadFile(PathFor(seed));
    ASSERT_FALSE(good.empty());
    for (int trial = 0; trial < 60; ++trial) {
      std::string bad = good;
      if (trial % 2 == 0) {
        bad.resize(std::uniform_int_distribution<std::size_t>(1, good.size() - 1)(rng));
      } else {
        for (int flips = 1 + static_cast<int>(rng() % 4); flips > 0; --flips) {
          bad[rng() % bad.size()] = static_cast<char>(rng());
        }
      }
      const std::string path = Write(std::string("mutant_") + seed, bad);
      Expected<LoadedCloud> result = LoadPointCloud(path);
      if (result.ok()) {
        ++successes;
        for (const auto& p : result->points) ASSERT_TRUE(p.allFinite()) << seed << " " << trial;
        ASSERT_LE(result->points.size(), result->raw_point_count);
      } else {
        ++failures;
        ASSERT_THAT(result.error().message, StartsWith(path)) << seed << " " << trial;
      }
    }
  }
  EXPECT_GT(failures, 100);  // Most mutations must be caught...
  EXPECT_GT(successes, 0);   // ...while a flipped coordinate byte still loads.
}

TEST_F(CloudIoTest, LoadingNeverPrints) {
  std::vector<Eigen::Vector3f> occupied;
  octomap::OcTree tree = SmallTree(&occupied);
  ASSERT_TRUE(tree.write(PathFor("good.ot")));
  ASSERT_TRUE(tree.writeBinary(PathFor("good.bt")));  // Prints " done." itself.
  const std::string paths[] = {
      PathFor("good.ot"),
      PathFor("good.bt"),
      Write("noise.pcd", "VERSION 0.7\nFIELDS x\nDATA ascii\n1\n"),
      Write("short.ply",
            "ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\n"
            "property float y\nproperty float z\nend_header\n1 2 3\n4 55555\n"),
      Write("bad.bt", "# Octomap OcTree binary file\nid OcTree\nsize 9\nres 0.1\ndata\n\xff"),
      Write("bad.ot", "# Octomap OcTree file\nid Weird\nsize 1\nres 0.1\ndata\n"),
      Write("ok.pcd", PcdHeader("WIDTH 0\nHEIGHT 0", 1, "ascii") + "1 2 3 4\n"),
  };
  ::testing::internal::CaptureStderr();
  ::testing::internal::CaptureStdout();
  int loaded = 0;
  for (const std::string& path : paths) loaded += LoadPointCloud(path).ok();
  const std::string out = ::testing::internal::GetCapturedStdout();
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(loaded, 3);
  EXPECT_EQ(out, "");
  EXPECT_EQ(err, "");
}

class SharedMapsTest : public ::testing::Test {
 protected:
  static std::string MapPath(const std::string& name) {
    return (fs::path(STRATA_SHARED_MAPS_DIR) / name).string();
  }
  static void ExpectMap(const std::string& name, std::size_t count, const Eigen::Vector3f& min,
                        const Eigen::Vector3f& max) {
    if (!fs::exists(MapPath(name))) {
      GTEST_SKIP() << MapPath(name) << " is absent: the shared reference maps live in "
                   << "../shared/maps beside the repository";
    }
    Expected<LoadedCloud> cloud = LoadPointCloud(MapPath(name));
    ASSERT_TRUE(cloud.ok()) << cloud.error().message;
    EXPECT_EQ(cloud->points.size(), count);
    EXPECT_EQ(cloud->raw_point_count, count);
    Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
    for (const auto& p : cloud->points) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    EXPECT_LT((lo - min).cwiseAbs().maxCoeff(), 0.15f) << lo.transpose();
    EXPECT_LT((hi - max).cwiseAbs().maxCoeff(), 0.15f) << hi.transpose();
  }
};

TEST_F(SharedMapsTest, Scene20LoadsWithDocumentedBounds) {
  ExpectMap("scene20.2.pcd", 72100, {-10.0f, -10.7f, -0.1f}, {20.0f, 19.9f, 6.65f});
}

TEST_F(SharedMapsTest, SpiralLoadsWithDocumentedBounds) {
  ExpectMap("spiral0.3_2.pcd", 231885, {-61.4f, -32.2f, -0.6f}, {20.2f, 8.6f, 22.8f});
}

}  // namespace
}  // namespace strata
