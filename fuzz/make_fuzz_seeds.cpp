// Writes the fuzzers' seed corpora, one directory per target under the directory given, from
// the built-in scenes and Strata's own writers (plus PCL's and OctoMap's for the encodings
// Strata does not write). Generated at build or test time, never committed.
//
//   make_fuzz_seeds DIR
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <octomap/OcTree.h>
#include <pcl/io/pcd_io.h>
#include <pcl/io/ply_io.h>
#include <pcl/point_types.h>

#include "floor_and_wall.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/io/cloud_io.hpp"
#include "strata/io/model_tiles.hpp"
#include "strata/io/saved_graph.hpp"
#include "strata/io/saved_model.hpp"
#include "strata/scenes/scenes.hpp"
#include "strata/v1/map_service.pb.h"
#include "strata/v1/planner_service.pb.h"

namespace {

namespace fs = std::filesystem;

void Write(const fs::path& file, const std::string& bytes) {
  fs::create_directories(file.parent_path());
  std::ofstream(file, std::ios::binary) << bytes;
}

// Every `step`-th point of a scene: a few hundred points keep each run fast.
strata::PointCloud Sample(const std::string& scene, std::size_t step) {
  const strata::PointCloud all = strata::GenerateScene(scene, 1, {}, 50'000'000).value();
  strata::PointCloud some;
  for (std::size_t i = 0; i < all.size(); i += step) some.push_back(all[i]);
  return some;
}

pcl::PointCloud<pcl::PointXYZ> ToPcl(const strata::PointCloud& cloud) {
  pcl::PointCloud<pcl::PointXYZ> out;
  for (const Eigen::Vector3f& p : cloud) out.push_back({p.x(), p.y(), p.z()});
  return out;
}

void PointCloudSeeds(const fs::path& dir) {
  const strata::PointCloud cloud = Sample("two_level_ramp", 400);
  const pcl::PointCloud<pcl::PointXYZ> points = ToPcl(cloud);
  const fs::path pcd = dir / "pcd";
  fs::create_directories(pcd);
  strata::SavePcd(cloud, (pcd / "binary.pcd").string());
  pcl::io::savePCDFileASCII((pcd / "ascii.pcd").string(), points);
  pcl::io::savePCDFileBinaryCompressed((pcd / "compressed.pcd").string(), points);
  Write(pcd / "tiny.pcd",
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n"
        "WIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\nDATA ascii\n0 0 0\n1 nan 2\n");
  const fs::path ply = dir / "ply";
  fs::create_directories(ply);
  pcl::io::savePLYFileASCII((ply / "ascii.ply").string(), points);
  pcl::io::savePLYFileBinary((ply / "binary.ply").string(), points);
  Write(ply / "tiny.ply",
        "ply\nformat ascii 1.0\ncomment seed\nelement vertex 2\nproperty float x\n"
        "property float y\nproperty float z\nend_header\n0 0 0\n1 2 3\n");
}

void OctomapSeeds(const fs::path& dir) {
  octomap::OcTree tree(0.2);
  for (const Eigen::Vector3f& p : Sample("uneven_terrain", 2000)) {
    tree.updateNode(octomap::point3d(p.x(), p.y(), p.z()), true);
  }
  tree.updateNode(octomap::point3d(0.1f, 0.1f, 3.0f), false);
  tree.prune();
  // The target's first byte picks the format: odd .bt, even .ot.
  std::ostringstream binary;
  tree.writeBinary(binary);
  Write(dir / "octomap" / "tree.bt", "\x01" + binary.str());
  std::ostringstream full;
  tree.write(full);
  Write(dir / "octomap" / "tree.ot", std::string("\x00", 1) + full.str());
}

void SavedModelSeeds(const fs::path& dir) {
  // A scene's model (hundreds of kilobytes) ran at 1,000 inputs a second; this one is small
  // enough that libFuzzer's default input length (4 KiB or the largest seed) keeps mutations
  // that small.
  const auto model = strata::fuzz::FloorAndWallModel();
  // Without its checksum, which the target appends (saved_model_fuzzer.cpp).
  const std::string saved = strata::SerializeModel(*model);
  Write(dir / "saved_model" / "floor_and_wall.smd", saved.substr(0, saved.size() - 8));
  // The graph of the default robot on it, likewise (saved_graph_fuzzer.cpp loads it onto the
  // same model).
  const auto graph = strata::SurfaceGraph::Build(*model, strata::TraversabilityParams{}).value();
  const std::string graph_bytes = strata::SerializeGraph(graph);
  Write(dir / "saved_graph" / "floor_and_wall.sgr", graph_bytes.substr(0, graph_bytes.size() - 8));
  // Its tiles, each part after its u32 length, the header without its checksum
  // (tiled_model_fuzzer.cpp).
  const strata::TiledModel tiled = strata::CutModel(*model);
  std::string parts;
  const auto add = [&parts](std::string_view part) {
    const auto length = static_cast<std::uint32_t>(part.size());
    parts.append(reinterpret_cast<const char*>(&length), sizeof(length));
    parts.append(part);
  };
  add(std::string_view(tiled.header).substr(0, tiled.header.size() - 8));
  for (const std::string& tile : tiled.tiles) add(tile);
  Write(dir / "tiled_model" / "floor_and_wall.tmd", parts);
}

// The upload target's framing: a 2-byte little-endian length, then a serialised message.
std::string Framed(const google::protobuf::MessageLite& message) {
  const std::string bytes = message.SerializeAsString();
  return std::string{static_cast<char>(bytes.size() & 0xFF),
                     static_cast<char>((bytes.size() >> 8) & 0xFF)} +
         bytes;
}

void UploadSeeds(const fs::path& dir) {
  strata::v1::UploadMapRequest header;
  header.mutable_header()->set_map_id("seed");
  header.mutable_header()->set_format(strata::v1::POINT_FORMAT_XYZ_F32_LE);
  header.mutable_header()->set_point_count(6);
  header.mutable_header()->mutable_terrain()->set_resolution_m(0.2);
  std::string points;
  for (const float v : {0.f, 0.f, 0.f, 1.f, 0.f, 0.f, 0.f, 1.f, 0.f}) {
    points.append(reinterpret_cast<const char*>(&v), sizeof v);
  }
  strata::v1::UploadMapRequest chunk;
  chunk.mutable_chunk()->set_points(points);
  Write(dir / "upload" / "two_chunks", Framed(header) + Framed(chunk) + Framed(chunk));
  header.mutable_header()->set_point_count(0);
  Write(dir / "upload" / "no_count", Framed(header) + Framed(chunk));
}

void PlanRequestSeeds(const fs::path& dir) {
  strata::v1::PlanRequest request;
  request.set_map_id("demo");
  request.set_profile_name("differential");
  request.mutable_start()->mutable_position_m()->set_x(2);
  request.mutable_start()->mutable_position_m()->set_y(2);
  request.mutable_goal()->mutable_position_m()->set_x(10);
  request.mutable_goal()->mutable_position_m()->set_z(3.3);
  request.mutable_options()->set_time_budget_s(2);
  Write(dir / "plan_request" / "named", request.SerializeAsString());
  request.mutable_profile()->set_max_step_m(0.12);
  request.mutable_profile()->set_reference_height_m(0.5);
  strata::v1::Prism* zone = request.add_keep_out();
  for (const auto& [x, y] : {std::pair{0., 0.}, {1., 0.}, {1., 1.}}) {
    strata::v1::Vector2* corner = zone->add_polygon_m();
    corner->set_x(x);
    corner->set_y(y);
  }
  zone->set_z_min_m(-1);
  zone->set_z_max_m(2);
  Write(dir / "plan_request" / "inline_with_zone", request.SerializeAsString());
}

// request_fuzzer's seeds: its selector byte, then a valid request of that kind.
void RequestSeeds(const fs::path& dir) {
  const auto write = [&](char selector, const std::string& name, const auto& message) {
    Write(dir / "request" / name, std::string(1, selector) + message.SerializeAsString());
  };
  strata::v1::Prism zone;
  for (const auto& [x, y] : {std::pair{0., 0.}, {2., 0.}, {2., 2.}, {0., 2.}}) {
    strata::v1::Vector2* corner = zone.add_polygon_m();
    corner->set_x(x);
    corner->set_y(y);
  }
  zone.set_z_min_m(0);
  zone.set_z_max_m(1);
  strata::v1::UpdateMapRequest update;
  update.set_map_id("demo");
  *update.add_edits()->mutable_add_obstacle() = zone;
  *update.add_edits()->mutable_remove_points() = zone;
  *update.add_edits()->mutable_add_keep_out() = zone;
  strata::v1::Scan* scan = update.add_edits()->mutable_scan();
  *scan->mutable_region() = zone;
  // Packed float32 x, y, z (little-endian, as the machines that fuzz are); the last point lies
  // outside the region.
  const float xyz[] = {0.5f, 0.5f, 0.1f, 1.5f, 1.5f, 0.2f, 3.0f, 3.0f, 0.0f};
  scan->set_points(std::string(reinterpret_cast<const char*>(xyz), sizeof(xyz)));
  write(0, "update_map", update);
  strata::v1::PlanBatchRequest batch;
  for (int i = 0; i < 2; ++i) {
    strata::v1::PlanRequest* item = batch.add_requests();
    item->set_map_id("demo");
    item->set_profile_name(i == 0 ? "differential" : "biped");
    item->mutable_goal()->mutable_position_m()->set_x(10);
    *item->add_keep_out() = zone;
  }
  write(1, "plan_batch", batch);
  strata::v1::EstimateCostsRequest costs;
  costs.set_map_id("demo");
  costs.set_profile_name("differential");
  costs.add_starts_m()->set_x(1);
  costs.add_goals_m()->set_y(8);
  costs.add_goals_m()->set_z(3.3);
  *costs.add_keep_out() = zone;
  write(2, "estimate_costs", costs);
  strata::v1::GetMapGeometryRequest geometry;
  geometry.set_map_id("demo");
  geometry.set_stride(2);
  geometry.mutable_profile()->set_max_step_m(0.12);
  write(3, "get_map_geometry", geometry);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: make_fuzz_seeds DIR\n");
    return 2;
  }
  const fs::path dir = argv[1];
  PointCloudSeeds(dir);
  OctomapSeeds(dir);
  SavedModelSeeds(dir);
  UploadSeeds(dir);
  PlanRequestSeeds(dir);
  RequestSeeds(dir);
  for (const char* target : {"pcd", "ply", "octomap", "saved_model", "saved_graph", "tiled_model",
                             "upload", "plan_request", "request"}) {
    std::size_t files = 0;
    for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir / target)) ++files;
    std::printf("%s: %zu seeds\n", target, files);
  }
  return 0;
}
