// Map files are confined to the map root: '..', absolute paths and symbolic links that
// leave it are refused, however the path reaches them, and what was checked is what is read.
#include "maps/map_root.hpp"

#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <fstream>
#include <iterator>
#include <thread>

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
    Result<std::shared_ptr<const OpenedMapFile>> opened =
        OpenMapFile(root_, requested, "file.path");
    EXPECT_FALSE(opened.ok()) << requested << " opened " << opened.value()->real_path();
    return opened.ok() ? ServiceError::Code(ErrorCode::kInvalidInput) : opened.error().code;
  }

  // Where `requested` opens, or "" when it is refused.
  std::string RealPathOf(const std::string& requested) {
    Result<std::shared_ptr<const OpenedMapFile>> opened = OpenMapFile(root_, requested, "f");
    return opened.ok() ? opened.value()->real_path().string() : std::string();
  }

  fs::path base_;
  fs::path root_;
};

TEST_F(MapRootTest, AcceptsFilesInsideTheRoot) {
  const std::string map = (root_ / "sub" / "map.pcd").string();
  EXPECT_EQ(RealPathOf("sub/map.pcd"), map);
  EXPECT_EQ(RealPathOf("./sub/../sub/map.pcd"), map);
  EXPECT_EQ(RealPathOf(map), map);
  // A link that stays inside is fine and resolves to its target.
  EXPECT_EQ(RealPathOf("inside_link.pcd"), map);
  EXPECT_EQ(RealPathOf("sub/../inside_link.pcd"), map);
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

// Every spelling that reaches a link out of the root is refused; weakly_canonical once read
// "missing/../escape.pcd" as the text "escape.pcd" and never resolved the link.
TEST_F(MapRootTest, RefusesEverySpellingOfALinkOutOfTheRoot) {
  const ServiceError::Code outside = ServiceErrorCode::kPathOutsideMapRoot;
  EXPECT_EQ(CodeOf("./escape.pcd"), outside);
  EXPECT_EQ(CodeOf("sub/../escape.pcd"), outside);
  EXPECT_EQ(CodeOf("sub/./../escape.pcd"), outside);
  EXPECT_EQ(CodeOf("sub/../../root/escape.pcd"), outside);
  EXPECT_EQ(CodeOf((root_ / "sub" / ".." / "escape.pcd").string()), outside);
  EXPECT_EQ(CodeOf("escape_dir"), outside);  // A link to a directory outside.
  EXPECT_EQ(CodeOf("./escape_dir/secret.pcd"), outside);
  EXPECT_EQ(CodeOf("sub/../escape_dir/secret.pcd"), outside);
  // A component that does not exist stops the kernel's walk: nothing is opened at all.
  EXPECT_EQ(std::get<ErrorCode>(CodeOf("missing/../escape.pcd")), ErrorCode::kMapLoadFailed);
  EXPECT_EQ(std::get<ErrorCode>(CodeOf("missing/../escape_dir/secret.pcd")),
            ErrorCode::kMapLoadFailed);
}

// The descriptor is what is read: a link swapped in after the check changes nothing.
TEST_F(MapRootTest, WhatWasCheckedIsWhatIsRead) {
  std::ofstream(root_ / "swap.pcd") << "checked";
  Result<std::shared_ptr<const OpenedMapFile>> opened = OpenMapFile(root_, "swap.pcd", "f");
  ASSERT_TRUE(opened.ok()) << opened.error().message;
  fs::remove(root_ / "swap.pcd");
  fs::create_symlink(base_ / "outside" / "secret.pcd", root_ / "swap.pcd");
  std::ifstream read(opened.value()->ProcPath());
  EXPECT_EQ(std::string(std::istreambuf_iterator<char>(read), {}), "checked");
}

// The path may change between the check of its text and the open: a file and a link out of
// the root swap places at one name while it is opened again and again. Whatever was opened is
// what its real path says, so nothing outside is ever handed on.
TEST_F(MapRootTest, ALinkSwappedInDuringTheCheckIsNeverOpened) {
  std::ofstream(root_ / "inside.pcd") << "inside";
  std::atomic<bool> swapping{true};
  std::thread swapper([&] {
    while (swapping) {
      fs::create_hard_link(root_ / "inside.pcd", root_ / "file.tmp");
      fs::rename(root_ / "file.tmp", root_ / "race.pcd");
      fs::create_symlink(base_ / "outside" / "secret.pcd", root_ / "link.tmp");
      fs::rename(root_ / "link.tmp", root_ / "race.pcd");
    }
  });
  int opened = 0;
  int refused = 0;
  for (int i = 0; i < 20000; ++i) {
    Result<std::shared_ptr<const OpenedMapFile>> file = OpenMapFile(root_, "race.pcd", "f");
    if (!file.ok()) {
      ++refused;
      continue;
    }
    ++opened;
    std::ifstream read(file.value()->ProcPath());
    ASSERT_EQ(std::string(std::istreambuf_iterator<char>(read), {}), "inside") << "attempt " << i;
  }
  swapping = false;
  swapper.join();
  EXPECT_GT(opened, 0);
  EXPECT_GT(refused, 0);
}

TEST_F(MapRootTest, AFifoIsRefusedWithoutWaitingForAWriter) {
  ASSERT_EQ(mkfifo((root_ / "fifo.pcd").c_str(), 0600), 0);
  EXPECT_EQ(std::get<ErrorCode>(CodeOf("fifo.pcd")), ErrorCode::kMapLoadFailed);
}

TEST_F(MapRootTest, NamesTheFieldAndTellsMissingFromRefused) {
  Result<std::shared_ptr<const OpenedMapFile>> missing =
      OpenMapFile(root_, "sub/nothing.pcd", "file.path");
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
  Result<std::shared_ptr<const OpenedMapFile>> resolved = OpenMapFile(root_, name, "file.path");
  ASSERT_FALSE(resolved.ok());
  EXPECT_EQ(std::get<ErrorCode>(resolved.error().code), ErrorCode::kInvalidInput);
  EXPECT_NE(resolved.error().message.find("too long"), std::string::npos)
      << resolved.error().message;
  EXPECT_LT(resolved.error().message.size(), 200u);
  Result<std::shared_ptr<const OpenedMapFile>> outside =
      OpenMapFile(root_, "../" + std::string(200, 'o'), "file.path");
  ASSERT_FALSE(outside.ok());
  EXPECT_LT(outside.error().message.size(), 250u);
}

TEST_F(MapRootTest, NoRootDisablesFiles) {
  Result<std::shared_ptr<const OpenedMapFile>> resolved =
      OpenMapFile(fs::path(), "sub/map.pcd", "file.path");
  ASSERT_FALSE(resolved.ok());
  EXPECT_EQ(std::get<ServiceErrorCode>(resolved.error().code),
            ServiceErrorCode::kPathOutsideMapRoot);
  EXPECT_FALSE(CanonicalMapRoot(base_ / "missing").ok());
}

}  // namespace
}  // namespace strata::server
