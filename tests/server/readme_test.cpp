// server/README.md's "Code" table names every source file of server/, so a newcomer finds each
// file's job there.
#include <filesystem>
#include <fstream>
#include <iterator>
#include <set>
#include <string>

#include <gtest/gtest.h>

namespace {

namespace fs = std::filesystem;

TEST(ServerReadmeTest, TheCodeTableNamesEverySourceFile) {
  const fs::path server = fs::path(STRATA_SOURCE_DIR) / "server";
  std::ifstream readme(server / "README.md");
  ASSERT_TRUE(readme);
  const std::string text{std::istreambuf_iterator<char>(readme), {}};
  const std::size_t table = text.find("\n## Code\n");
  ASSERT_NE(table, std::string::npos);
  const std::string code = text.substr(table);
  std::set<std::string> missing;
  int files = 0;
  for (const auto& entry : fs::recursive_directory_iterator(server)) {
    const fs::path& path = entry.path();
    if (path.extension() != ".cpp" && path.extension() != ".hpp") continue;
    ++files;
    // "maps/map_store.cpp" is named as `maps/map_store.*` or by its whole name.
    const std::string relative = fs::relative(path, server).replace_extension().string();
    if (code.find("`" + relative + ".*`") == std::string::npos &&
        code.find("`" + relative + path.extension().string() + "`") == std::string::npos) {
      missing.insert(fs::relative(path, server).string());
    }
  }
  EXPECT_GT(files, 40);
  EXPECT_TRUE(missing.empty()) << "not in server/README.md's Code table: " << [&] {
    std::string list;
    for (const std::string& file : missing) list += file + " ";
    return list;
  }();
}

}  // namespace
