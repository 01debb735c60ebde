// Bearer tokens and roles (server/rpc/auth.hpp).
#include "rpc/auth.hpp"

#include <unistd.h>

#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;

const std::string kPlannerToken = "planner-token-0123456789";
const std::string kAdminToken = "admin-token-0123456789ab";

class TokenFileTest : public ::testing::Test {
 protected:
  std::filesystem::path Write(const std::string& text) {
    const auto path =
        std::filesystem::temp_directory_path() /
        ("strata_tokens_" + std::to_string(::getpid()) + "_" + std::to_string(count_++));
    std::ofstream(path) << text;
    paths_.push_back(path);
    return path;
  }
  void TearDown() override {
    for (const auto& path : paths_) std::filesystem::remove(path);
  }

 private:
  int count_ = 0;
  std::vector<std::filesystem::path> paths_;
};

ServiceErrorCode CodeOf(const ServiceStatus& status) {
  return std::get<ServiceErrorCode>(status.error().code);
}

TEST_F(TokenFileTest, ReadsTokensAndRolesSkippingCommentsAndBlankLines) {
  Result<TokenTable> table = TokenTable::Load(
      Write("# who may do what\n\n" + kPlannerToken + " planner\n  " + kAdminToken + "  admin\n"));
  ASSERT_TRUE(table.ok()) << table.error().message;
  EXPECT_EQ(table->size(), 2u);
}

TEST_F(TokenFileTest, RefusesMalformedFilesNamingTheLineButNeverTheToken) {
  const std::string secret = "a-secret-token-0123456789";
  const std::pair<std::string, std::string> cases[] = {
      {secret + "\n", "line 1: expected `TOKEN ROLE`"},
      {secret + " root\n", "line 1: the role must be planner or admin"},
      {"# c\nshort planner\n", "line 2: a token is 16 to 256"},
      {secret + " planner extra\n", "line 1: expected `TOKEN ROLE`"},
      {secret + " planner\n" + secret + " admin\n", "line 2: this token is listed twice"},
      {"# nothing\n", "holds no `TOKEN ROLE` line"},
  };
  for (const auto& [text, expected] : cases) {
    Result<TokenTable> table = TokenTable::Load(Write(text));
    ASSERT_FALSE(table.ok()) << text;
    EXPECT_THAT(table.error().message, HasSubstr(expected));
    EXPECT_THAT(table.error().message, Not(HasSubstr(secret)));
  }
  EXPECT_FALSE(TokenTable::Load("/nonexistent/tokens").ok());
}

TEST(TokenTableTest, RolesDecideWhatATokenMayDo) {
  const TokenTable table({{kPlannerToken, Role::kPlanner}, {kAdminToken, Role::kAdmin}});
  EXPECT_TRUE(table.Authorize("Bearer " + kPlannerToken, Role::kPlanner).ok());
  EXPECT_TRUE(table.Authorize("Bearer " + kAdminToken, Role::kPlanner).ok());
  EXPECT_TRUE(table.Authorize("Bearer " + kAdminToken, Role::kAdmin).ok());
  EXPECT_EQ(CodeOf(table.Authorize("Bearer " + kPlannerToken, Role::kAdmin)),
            ServiceErrorCode::kPermissionDenied);
  for (const std::string& bad :
       {std::string(), kAdminToken, "Basic " + kAdminToken, "Bearer " + kAdminToken + "x",
        "Bearer " + kAdminToken.substr(0, 10), std::string("Bearer ")}) {
    const ServiceStatus status = table.Authorize(bad, Role::kPlanner);
    ASSERT_FALSE(status.ok()) << bad;
    EXPECT_EQ(CodeOf(status), ServiceErrorCode::kUnauthenticated) << bad;
    EXPECT_THAT(status.error().message, Not(HasSubstr(kAdminToken)));
  }
}

}  // namespace
}  // namespace strata::server
