// Local point files for `strata maps upload`: PCD (binary and ascii, extra fields, double
// coordinates), text and raw, read in chunks as float32 x, y, z; malformed files named.
#include "point_file.hpp"

#include <cstring>
#include <filesystem>
#include <fstream>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "context.hpp"

namespace strata::cli {
namespace {

using ::testing::HasSubstr;

class PointFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = std::filesystem::temp_directory_path() /
           ("strata_point_file_test_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& contents) {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << contents;
    return path;
  }

  // Reads every point in chunks of `chunk_points`; returns them as floats.
  static std::vector<float> ReadAll(PointFileReader& reader, std::size_t chunk_points,
                                    int* chunks = nullptr) {
    std::vector<float> values;
    std::string chunk;
    int count = 0;
    while (reader.Next(chunk_points, &chunk)) {
      EXPECT_EQ(chunk.size() % 12, 0u);
      EXPECT_LE(chunk.size(), chunk_points * 12);
      const std::size_t n = chunk.size() / 4;
      const std::size_t old = values.size();
      values.resize(old + n);
      std::memcpy(values.data() + old, chunk.data(), chunk.size());
      ++count;
    }
    if (chunks != nullptr) *chunks = count;
    return values;
  }

  std::filesystem::path dir_;
};

TEST_F(PointFileTest, BinaryPcdWithExtraFieldsAndDoubles) {
  std::string body;
  // FIELDS intensity x y z: float intensity, float x, double y, float z.
  for (int i = 0; i < 5; ++i) {
    const float intensity = 100.0f + i, x = 1.0f * i, z = -0.5f * i;
    const double y = 0.25 * i;
    body.append(reinterpret_cast<const char*>(&intensity), 4);
    body.append(reinterpret_cast<const char*>(&x), 4);
    body.append(reinterpret_cast<const char*>(&y), 8);
    body.append(reinterpret_cast<const char*>(&z), 4);
  }
  const std::string path =
      Write("cloud.pcd",
            "# .PCD v0.7\nVERSION 0.7\nFIELDS intensity x y z\nSIZE 4 4 8 4\nTYPE F F F F\n"
            "COUNT 1 1 1 1\nWIDTH 5\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 5\nDATA binary\n" +
                body);
  ASSERT_EQ(GuessPointFileFormat(path), PointFileFormat::kPcd);
  PointFileReader reader(path, PointFileFormat::kPcd);
  EXPECT_EQ(reader.point_count(), 5u);
  int chunks = 0;
  const std::vector<float> values = ReadAll(reader, 2, &chunks);
  EXPECT_EQ(chunks, 3);  // 2 + 2 + 1.
  ASSERT_EQ(values.size(), 15u);
  for (int i = 0; i < 5; ++i) {
    EXPECT_EQ(values[3 * i], 1.0f * i);
    EXPECT_EQ(values[3 * i + 1], 0.25f * i);
    EXPECT_EQ(values[3 * i + 2], -0.5f * i);
  }
}

TEST_F(PointFileTest, AsciiPcdAndTextAndRaw) {
  const std::string pcd =
      Write("a.pcd",
            "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\n"
            "DATA ascii\n1 2 3 77\n4.5 5 6 78\n");
  PointFileReader pcd_reader(pcd, PointFileFormat::kPcd);
  EXPECT_EQ(pcd_reader.point_count(), 2u);  // WIDTH × HEIGHT without POINTS.
  EXPECT_EQ(ReadAll(pcd_reader, 10), (std::vector<float>{1, 2, 3, 4.5f, 5, 6}));

  const std::string text = Write("b.xyz", "# x y z\n1,2,3\n\n-4 5 6 0.9\n");
  PointFileReader text_reader(text, *GuessPointFileFormat(text));
  EXPECT_EQ(text_reader.point_count(), 0u);  // Unknown in advance.
  EXPECT_EQ(ReadAll(text_reader, 1), (std::vector<float>{1, 2, 3, -4, 5, 6}));

  const float raw_points[6] = {7, 8, 9, 10, 11, 12};
  const std::string raw =
      Write("c.bin", std::string(reinterpret_cast<const char*>(raw_points), 24));
  PointFileReader raw_reader(raw, PointFileFormat::kRawF32);
  EXPECT_EQ(raw_reader.point_count(), 2u);
  EXPECT_EQ(ReadAll(raw_reader, 5), (std::vector<float>{7, 8, 9, 10, 11, 12}));
}

std::string Failure(const std::function<void()>& f) {
  try {
    f();
  } catch (const UsageError& error) {
    return error.what();
  }
  return "(no error)";
}

TEST_F(PointFileTest, MalformedFilesAreNamed) {
  const std::string compressed = Write("c.pcd",
                                       "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 1\nHEIGHT "
                                       "1\nPOINTS 1\nDATA binary_compressed\n");
  EXPECT_THAT(Failure([&] { PointFileReader(compressed, PointFileFormat::kPcd); }),
              HasSubstr("PCD DATA binary_compressed is not supported"));
  const std::string no_z =
      Write("d.pcd", "FIELDS x y\nSIZE 4 4\nTYPE F F\nPOINTS 1\nDATA ascii\n1 2\n");
  EXPECT_THAT(Failure([&] { PointFileReader(no_z, PointFileFormat::kPcd); }),
              HasSubstr("PCD has no x, y and z fields"));
  const std::string truncated =
      Write("e.pcd", "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nPOINTS 3\nDATA binary\n" +
                         std::string(20, '\0'));
  EXPECT_THAT(Failure([&] {
                PointFileReader reader(truncated, PointFileFormat::kPcd);
                std::string chunk;
                while (reader.Next(10, &chunk)) {
                }
              }),
              HasSubstr("ends after 1 of 3 points"));
  const std::string bad_text = Write("f.txt", "1 2 3\n1 two 3\n");
  EXPECT_THAT(Failure([&] {
                PointFileReader reader(bad_text, PointFileFormat::kText);
                std::string chunk;
                while (reader.Next(10, &chunk)) {
                }
              }),
              HasSubstr("line 2: \"two\" is not a number"));
  const std::string odd_raw = Write("g.raw", std::string(13, '\0'));
  EXPECT_THAT(Failure([&] { PointFileReader(odd_raw, PointFileFormat::kRawF32); }),
              HasSubstr("has 13 bytes, not a multiple of 12"));
  EXPECT_THAT(
      Failure([&] { PointFileReader((dir_ / "none.pcd").string(), PointFileFormat::kPcd); }),
      HasSubstr("cannot read"));
  EXPECT_FALSE(GuessPointFileFormat("cloud.ply").has_value());
  EXPECT_EQ(ParsePointFileFormat("raw"), PointFileFormat::kRawF32);
  EXPECT_FALSE(ParsePointFileFormat("las").has_value());
}

}  // namespace
}  // namespace strata::cli
