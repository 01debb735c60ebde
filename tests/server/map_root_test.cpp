// Map files are confined to the map root: '..', absolute paths and symbolic links that
// leave it are refused before anything about them is revealed.
#include "map_root.hpp"

#include <unistd.h>

#include <fstream>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

namespace fs = std::filesystem;

class MapRootTest : public ::testing::Test {
 protected:
  void SetUp() override {
    base_ = fs::temp_directory_path() /
            ("strata_map_root_test_" + std::to_string(::getpid()) + "_" +
             ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(base_ / "root" / "sub");
    fs::create_directories(base_ / "root2");
    fs::create_directories(base_ / "outside");
    std::ofstream(base_ / "root" / "sub" / "map.pcd") << "x";
    std::ofstream(base_ / "root2" / "other.pcd") << "x";
    std::ofstream(base_ / "outside" / "secret.pcd") << "x";
    fs::create_symlink(base_ / "outside" / "secret.pcd", base_ / "root" / "escape.pcd");
    fs::create_directory_symlink(base_ / "outside", base_ / "root" / "escape_dir");
    fs::create_symlink(base_ / "root" / "sub" / "map.pcd", base_ / "root" / "inside_link.pcd");
    root_ = CanonicalMapRoot(base_ / "root").value();
  }
  void TearDown() override { fs::remove_all(base_); }

  ServiceError::Code CodeOf(const std::string& requested) {
    Result<fs::path> resolved = ResolveMapPath(root_, requested, "file.path");
    EXPECT_FALSE(resolved.ok()) << requested;
    return resolved.ok() ? ServiceError::Code(ErrorCode::kInvalidInput) : resolved.error().code;
  }

  fs::path base_;
  fs::path root_;
};

TEST_F(MapRootTest, AcceptsFilesInsideTheRoot) {
  EXPECT_EQ(ResolveMapPath(root_, "sub/map.pcd", "f").value(), root_ / "sub" / "map.pcd");
  EXPECT_EQ(ResolveMapPath(root_, "./sub/../sub/map.pcd", "f").value(), root_ / "sub" / "map.pcd");
  EXPECT_EQ(ResolveMapPath(root_, (root_ / "sub/map.pcd").string(), "f").value(),
            root_ / "sub" / "map.pcd");
  // A link that stays inside is fine and resolves to its target.
  EXPECT_EQ(ResolveMapPath(root_, "inside_link.pcd", "f").value(), root_ / "sub" / "map.pcd");
}

TEST_F(MapRootTest, RefusesEverythingThatLeavesTheRoot) {
  const ServiceError::Code outside = ServiceErrorCode::kPathOutsideMapRoot;
  EXPECT_EQ(CodeOf("../outside/secret.pcd"), outside);
  EXPECT_EQ(CodeOf("sub/../../outside/secret.pcd"), outside);
  EXPECT_EQ(CodeOf((base_ / "outside" / "secret.pcd").string()), outside);
  EXPECT_EQ(CodeOf("/etc/passwd"), outside);
  EXPECT_EQ(CodeOf("escape.pcd"), outside);             // Symlink to a file outside.
  EXPECT_EQ(CodeOf("escape_dir/secret.pcd"), outside);  // Through a symlinked directory.
  EXPECT_EQ(CodeOf("../root2/other.pcd"), outside);     // A sibling sharing the prefix.
  // Refused before existence is checked: a missing file outside says nothing more.
  EXPECT_EQ(CodeOf("../outside/missing.pcd"), outside);
}

TEST_F(MapRootTest, NamesTheFieldAndTellsMissingFromRefused) {
  Result<fs::path> missing = ResolveMapPath(root_, "sub/nothing.pcd", "file.path");
  ASSERT_FALSE(missing.ok());
  EXPECT_EQ(std::get<ErrorCode>(missing.error().code), ErrorCode::kMapLoadFailed);
  ASSERT_EQ(missing.error().field_violations.size(), 1u);
  EXPECT_EQ(missing.error().field_violations[0].field, "file.path");
  EXPECT_EQ(std::get<ErrorCode>(CodeOf("sub")), ErrorCode::kMapLoadFailed);  // A directory.
  EXPECT_EQ(std::get<ErrorCode>(CodeOf("")), ErrorCode::kInvalidInput);
  EXPECT_EQ(std::get<ErrorCode>(CodeOf(std::string("a\0b", 3))), ErrorCode::kInvalidInput);
}

// A name over 255 bytes was reported as "outside the map root", which sends a user looking
// for the wrong mistake; the quoted path is cut, whatever its length.
TEST_F(MapRootTest, ATooLongNameIsToldAsSuchAndQuotedShort) {
  const std::string name = "sub/" + std::string(300, 'n') + ".pcd";
  Result<fs::path> resolved = ResolveMapPath(root_, name, "file.path");
  ASSERT_FALSE(resolved.ok());
  EXPECT_EQ(std::get<ErrorCode>(resolved.error().code), ErrorCode::kInvalidInput);
  EXPECT_NE(resolved.error().message.find("too long"), std::string::npos)
      << resolved.error().message;
  EXPECT_LT(resolved.error().message.size(), 200u);
  Result<fs::path> outside = ResolveMapPath(root_, "../" + std::string(200, 'o'), "file.path");
  ASSERT_FALSE(outside.ok());
  EXPECT_LT(outside.error().message.size(), 250u);
}

TEST_F(MapRootTest, NoRootDisablesFiles) {
  Result<fs::path> resolved = ResolveMapPath(fs::path(), "sub/map.pcd", "file.path");
  ASSERT_FALSE(resolved.ok());
  EXPECT_EQ(std::get<ServiceErrorCode>(resolved.error().code),
            ServiceErrorCode::kPathOutsideMapRoot);
  EXPECT_FALSE(CanonicalMapRoot(base_ / "missing").ok());
}

}  // namespace
}  // namespace strata::server
