// The UploadMap stream protocol, message by message.
#include "rpc/upload_assembler.hpp"

#include <cstring>

#include <gtest/gtest.h>

#include "rpc/error_mapping.hpp"

namespace strata::server {
namespace {

v1::UploadMapRequest Header(std::uint64_t point_count = 0) {
  v1::UploadMapRequest message;
  message.mutable_header()->set_map_id("up");
  message.mutable_header()->set_format(v1::POINT_FORMAT_XYZ_F32_LE);
  message.mutable_header()->set_point_count(point_count);
  return message;
}

v1::UploadMapRequest Chunk(const std::vector<float>& xyz) {
  v1::UploadMapRequest message;
  std::string bytes(xyz.size() * sizeof(float), '\0');
  std::memcpy(bytes.data(), xyz.data(), bytes.size());  // This test runs little-endian.
  message.mutable_chunk()->set_points(bytes);
  return message;
}

std::string ReasonOf(const ServiceStatus& status) {
  return status.ok() ? "OK" : std::string(MapError(status.error().code).reason);
}

std::string FieldOf(const ServiceStatus& status) {
  return status.ok() || status.error().field_violations.empty()
             ? ""
             : status.error().field_violations[0].field;
}

TEST(UploadAssemblerTest, ReassemblesChunksInOrder) {
  UploadAssembler upload(100);
  ASSERT_TRUE(upload.Add(Header(3)).ok());
  ASSERT_TRUE(upload.Add(Chunk({1, 2, 3, 4, 5, 6})).ok());
  ASSERT_TRUE(upload.Add(Chunk({7, 8, 9})).ok());
  ASSERT_TRUE(upload.Finish().ok());
  UploadMapSource source = upload.TakeSource();
  ASSERT_EQ(source.points.size(), 3u);
  EXPECT_EQ(source.points[2], Eigen::Vector3f(7, 8, 9));
  EXPECT_EQ(source.received_bytes, 36u);
}

TEST(UploadAssemblerTest, RefusesMalformedStreams) {
  {
    UploadAssembler upload(100);
    const ServiceStatus s = upload.Add(Chunk({1, 2, 3}));
    EXPECT_EQ(ReasonOf(s), "MAP_LOAD_FAILED");
    EXPECT_EQ(FieldOf(s), "header");
  }
  {
    UploadAssembler upload(100);
    ASSERT_TRUE(upload.Add(Header()).ok());
    EXPECT_EQ(ReasonOf(upload.Add(Header())), "MAP_LOAD_FAILED");
  }
  {
    UploadAssembler upload(100);
    ASSERT_TRUE(upload.Add(Header()).ok());
    v1::UploadMapRequest partial = Chunk({1, 2, 3});
    partial.mutable_chunk()->mutable_points()->push_back('\0');  // 13 bytes.
    const ServiceStatus s = upload.Add(partial);
    EXPECT_EQ(ReasonOf(s), "MAP_LOAD_FAILED");
    EXPECT_EQ(FieldOf(s), "chunk.points");
  }
  {
    UploadAssembler upload(1'000'000);
    ASSERT_TRUE(upload.Add(Header()).ok());
    v1::UploadMapRequest big;
    big.mutable_chunk()->set_points(std::string(UploadAssembler::kMaxChunkBytes + 12, '\0'));
    EXPECT_EQ(ReasonOf(upload.Add(big)), "MAP_LOAD_FAILED");
  }
  {
    UploadAssembler upload(100);
    ASSERT_TRUE(upload.Add(Header(5)).ok());
    ASSERT_TRUE(upload.Add(Chunk({1, 2, 3})).ok());
    const ServiceStatus s = upload.Finish();
    EXPECT_EQ(ReasonOf(s), "MAP_LOAD_FAILED");
    EXPECT_EQ(FieldOf(s), "header.point_count");
  }
  {
    UploadAssembler upload(100);
    ASSERT_TRUE(upload.Add(Header()).ok());
    EXPECT_EQ(ReasonOf(upload.Finish()), "MAP_LOAD_FAILED");  // No points.
  }
  {
    UploadAssembler upload(100);
    EXPECT_EQ(ReasonOf(upload.Finish()), "MAP_LOAD_FAILED");  // Empty stream.
    EXPECT_EQ(ReasonOf(upload.Add(v1::UploadMapRequest())), "MAP_LOAD_FAILED");
  }
}

TEST(UploadAssemblerTest, ChecksTheHeader) {
  {
    UploadAssembler upload(100);
    v1::UploadMapRequest header = Header();
    header.mutable_header()->set_format(v1::POINT_FORMAT_UNSPECIFIED);
    const ServiceStatus s = upload.Add(header);
    EXPECT_EQ(ReasonOf(s), "INVALID_INPUT");
    EXPECT_EQ(FieldOf(s), "header.format");
  }
  {
    UploadAssembler upload(100);
    v1::UploadMapRequest header = Header();
    header.mutable_header()->mutable_terrain()->set_resolution_m(-1);
    const ServiceStatus s = upload.Add(header);
    EXPECT_EQ(ReasonOf(s), "INVALID_CONFIG");
    EXPECT_EQ(FieldOf(s), "header.terrain.resolution_m");
  }
  {
    UploadAssembler upload(100);
    v1::UploadMapRequest header = Header();
    header.mutable_header()->set_map_id("no spaces");
    EXPECT_EQ(FieldOf(upload.Add(header)), "header.map_id");
  }
}

TEST(UploadAssemblerTest, StopsAtTheServersPointLimit) {
  UploadAssembler upload(2);
  EXPECT_EQ(ReasonOf(upload.Add(Header(3))), "RESOURCE_EXHAUSTED");
  UploadAssembler streaming(2);
  ASSERT_TRUE(streaming.Add(Header()).ok());
  ASSERT_TRUE(streaming.Add(Chunk({1, 2, 3, 4, 5, 6})).ok());
  EXPECT_EQ(ReasonOf(streaming.Add(Chunk({7, 8, 9}))), "RESOURCE_EXHAUSTED");
}

TEST(UploadAssemblerTest, CountsItsPointsInTheMemoryBudgetAsTheyArrive) {
  constexpr std::uint64_t kPoint = sizeof(PointCloud::value_type);
  MemoryBudget budget(100 * kPoint);
  {
    // A header that announces more than the budget holds is refused before any chunk.
    UploadAssembler upload(1000, &budget);
    const ServiceStatus s = upload.Add(Header(101));
    EXPECT_EQ(ReasonOf(s), "RESOURCE_EXHAUSTED");
    EXPECT_EQ(FieldOf(s), "header.point_count");
    EXPECT_NE(s.error().message.find("uploading map 'up'"), std::string::npos);
  }
  EXPECT_EQ(budget.reserved(MemoryBudget::Use::kUploads), 0u);
  {
    // Without a count, each chunk is counted as the vector grows, and the one past it fails.
    UploadAssembler upload(1000, &budget);
    ASSERT_TRUE(upload.Add(Header()).ok());
    std::vector<float> ten(30, 1.0f);
    int accepted = 0;
    ServiceStatus s = OkStatus();
    while ((s = upload.Add(Chunk(ten))).ok()) ++accepted;
    EXPECT_EQ(ReasonOf(s), "RESOURCE_EXHAUSTED");
    EXPECT_EQ(FieldOf(s), "chunk.points");
    EXPECT_GE(accepted, 3);  // 40 points, doubled to 80, fit; 160 do not.
    EXPECT_LE(accepted * 10, 100);
    EXPECT_LE(budget.reserved(MemoryBudget::Use::kUploads), 100 * kPoint);
    EXPECT_GE(budget.reserved(MemoryBudget::Use::kUploads), accepted * 10 * kPoint);
  }
  EXPECT_EQ(budget.reserved(MemoryBudget::Use::kUploads), 0u);  // The failed upload let go.
  // A finished upload hands its share to its source, which holds it until the points go.
  UploadAssembler upload(1000, &budget);
  ASSERT_TRUE(upload.Add(Header(50)).ok());
  ASSERT_TRUE(upload.Add(Chunk(std::vector<float>(150, 2.0f))).ok());
  ASSERT_TRUE(upload.Finish().ok());
  {
    const UploadMapSource source = upload.TakeSource();
    EXPECT_EQ(budget.reserved(MemoryBudget::Use::kUploads), 50 * kPoint);
    ASSERT_NE(source.reservation, nullptr);
    EXPECT_EQ(source.reservation->bytes(), 50 * kPoint);
  }
  EXPECT_EQ(budget.reserved(MemoryBudget::Use::kUploads), 0u);
}

}  // namespace
}  // namespace strata::server
