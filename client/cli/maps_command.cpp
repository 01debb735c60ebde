// `strata maps create|upload|get|list|delete`.
#include <cmath>
#include <numbers>

#include "commands.hpp"
#include "output.hpp"
#include "point_file.hpp"
#include "strata/client/rpc.hpp"
#include "strata/v1/map_service.grpc.pb.h"

namespace strata::cli {
namespace {

// At most 1 MiB of whole 12-byte points per chunk (map_service.proto PointChunk).
constexpr std::size_t kMaxChunkPoints = (1 << 20) / 12;

std::unique_ptr<v1::MapService::Stub> Stub(const Context& ctx) {
  return v1::MapService::NewStub(client::MakeChannel(ctx.server));
}

const char* StateName(v1::MapState state) {
  switch (state) {
    case v1::MAP_STATE_CREATING: return "CREATING";
    case v1::MAP_STATE_ACTIVE: return "ACTIVE";
    case v1::MAP_STATE_FAILED: return "FAILED";
    default: return "UNSPECIFIED";
  }
}

std::string SourceText(const v1::MapSource& source) {
  if (source.has_file()) return "file " + source.file().path();
  if (source.has_scene()) {
    return "scene " + source.scene().name() + ":" + std::to_string(source.scene().seed());
  }
  if (source.has_upload())
    return "upload " + std::to_string(source.upload().received_bytes()) + " B";
  return "-";
}

std::string Megabytes(std::uint64_t bytes) { return Fixed(static_cast<double>(bytes) / 1e6, 1); }

void PrintMap(const Context& ctx, const v1::Map& map) {
  std::ostream& out = *ctx.out;
  if (ctx.json) {
    out << ToJson(map);
    return;
  }
  out << "map " << map.id() << ": " << StateName(map.state());
  if (map.state() == v1::MAP_STATE_CREATING) {
    out << " (" << Fixed(100 * map.progress(), 0) << "% done)";
  }
  out << "\n  source      " << SourceText(map.source()) << "\n";
  if (map.state() == v1::MAP_STATE_FAILED) {
    out << "  failure     " << map.failure().reason() << ": " << map.failure().message() << "\n";
  }
  const v1::TerrainParameters& terrain = map.terrain();
  out << "  terrain     resolution " << Fixed(terrain.resolution_m(), 3) << " m, ground radius "
      << Fixed(terrain.ground_radius_m(), 3) << " m, max tilt "
      << Fixed(terrain.max_tilt_rad() * 180 / std::numbers::pi, 1) << " deg\n";
  out << "  points      " << map.raw_point_count() << " raw, " << map.input_point_count()
      << " finite, " << map.valid_ground_point_count() << " valid ground\n";
  if (map.state() == v1::MAP_STATE_ACTIVE) {
    out << "  bounds      " << FormatVector(map.bounds_m().min_m()) << " to "
        << FormatVector(map.bounds_m().max_m()) << " m\n";
    out << "  grid        " << map.grid_size().nx() << " x " << map.grid_size().ny() << " x "
        << map.grid_size().nz() << " cells, " << map.max_levels() << " level(s) at most\n";
    out << "  memory      " << Megabytes(map.memory_bytes()) << " MB\n";
    out << "  assessment  " << Fixed(map.assessment_seconds().total_s(), 2) << " s (load "
        << Fixed(map.assessment_seconds().load_s(), 2) << " s)\n";
  }
}

// Terrain flags shared by create and upload.
void TakeTerrain(Arguments& args, v1::TerrainParameters* terrain) {
  if (auto v = args.TakeDouble("resolution")) terrain->set_resolution_m(*v);
  if (auto v = args.TakeDouble("ground-radius")) terrain->set_ground_radius_m(*v);
  if (auto v = args.TakeDouble("max-tilt")) terrain->set_max_tilt_rad(*v);
  if (auto v = args.TakeDouble("height-tolerance")) terrain->set_height_tolerance_m(*v);
  if (auto v = args.TakeDouble("padding")) terrain->set_padding_m(*v);
}

int Create(const Context& ctx, Arguments& args) {
  v1::CreateMapRequest request;
  request.set_map_id(args.NextPositional().value_or(""));
  const auto file = args.Take("file");
  const auto scene = args.Take("scene");
  const auto seed = args.TakeInteger("seed", 0, 4294967295LL);
  if (file.has_value() == scene.has_value()) {
    throw UsageError("maps create needs exactly one of --file PATH and --scene NAME");
  }
  if (file) request.mutable_file()->set_path(*file);
  if (scene) {
    request.mutable_scene()->set_name(*scene);
    request.mutable_scene()->set_seed(static_cast<std::uint32_t>(seed.value_or(0)));
  } else if (seed) {
    throw UsageError("--seed goes with --scene");
  }
  TakeTerrain(args, request.mutable_terrain());
  request.set_wait(args.TakeBool("wait"));
  args.Finish();

  grpc::ClientContext call;
  client::SetDeadline(&call, ctx.deadline_s);
  v1::Map map;
  const grpc::Status status = Stub(ctx)->CreateMap(&call, request, &map);
  if (!status.ok()) return ReportRpcError(ctx, "CreateMap", status);
  PrintMap(ctx, map);
  return kExitOk;
}

int Upload(const Context& ctx, Arguments& args) {
  const auto id = args.NextPositional();
  const auto path = args.NextPositional();
  if (!id || !path) throw UsageError("maps upload needs a map id and a file: maps upload ID FILE");
  std::optional<PointFileFormat> format;
  if (auto name = args.Take("format")) {
    format = ParsePointFileFormat(*name);
    if (!format) throw UsageError("--format must be pcd, xyz or raw, got \"" + *name + "\"");
  } else {
    format = GuessPointFileFormat(*path);
    if (!format) {
      throw UsageError("cannot tell the format of \"" + *path +
                       "\" from its extension; give --format pcd, xyz or raw");
    }
  }
  const std::size_t chunk_points = static_cast<std::size_t>(
      args.TakeInteger("chunk-points", 1, kMaxChunkPoints).value_or(kMaxChunkPoints));
  v1::UploadMapRequest header;
  header.mutable_header()->set_map_id(*id);
  header.mutable_header()->set_format(v1::POINT_FORMAT_XYZ_F32_LE);
  TakeTerrain(args, header.mutable_header()->mutable_terrain());
  header.mutable_header()->set_wait(args.TakeBool("wait"));
  args.Finish();

  PointFileReader reader(*path, *format);  // Throws before any call for an unusable file.
  header.mutable_header()->set_point_count(reader.point_count());

  grpc::ClientContext call;
  client::SetDeadline(&call, ctx.deadline_s);
  v1::Map map;
  auto stream = Stub(ctx)->UploadMap(&call, &map);
  bool sending = stream->Write(header);
  v1::UploadMapRequest chunk;
  std::string* points = chunk.mutable_chunk()->mutable_points();
  // A failed Write means the server ended the call; Finish() then has its status.
  try {
    while (sending && reader.Next(chunk_points, points)) sending = stream->Write(chunk);
  } catch (const UsageError&) {
    call.TryCancel();  // A malformed file part-way: abandon the upload, then report the file.
    stream->Finish();
    throw;
  }
  if (sending) stream->WritesDone();
  const grpc::Status status = stream->Finish();
  if (!status.ok()) return ReportRpcError(ctx, "UploadMap", status);
  PrintMap(ctx, map);
  return kExitOk;
}

int Get(const Context& ctx, Arguments& args) {
  const auto id = args.NextPositional();
  if (!id) throw UsageError("maps get needs a map id");
  args.Finish();
  v1::GetMapRequest request;
  request.set_map_id(*id);
  grpc::ClientContext call;
  client::SetDeadline(&call, ctx.deadline_s);
  v1::Map map;
  const grpc::Status status = Stub(ctx)->GetMap(&call, request, &map);
  if (!status.ok()) return ReportRpcError(ctx, "GetMap", status);
  PrintMap(ctx, map);
  return kExitOk;
}

int List(const Context& ctx, Arguments& args) {
  const auto page_size = args.TakeInteger("page-size", 0, 1000);
  const auto page_token = args.Take("page-token");
  args.Finish();
  // With --page-size or --page-token: that one page. Otherwise every page, merged.
  const bool one_page = page_size.has_value() || page_token.has_value();
  auto stub = Stub(ctx);
  v1::ListMapsRequest request;
  request.set_page_size(static_cast<int>(page_size.value_or(0)));
  request.set_page_token(page_token.value_or(""));
  v1::ListMapsResponse all;
  do {
    grpc::ClientContext call;
    client::SetDeadline(&call, ctx.deadline_s);
    v1::ListMapsResponse page;
    const grpc::Status status = stub->ListMaps(&call, request, &page);
    if (!status.ok()) return ReportRpcError(ctx, "ListMaps", status);
    for (v1::Map& map : *page.mutable_maps()) *all.add_maps() = std::move(map);
    all.set_next_page_token(one_page ? page.next_page_token() : "");
    request.set_page_token(page.next_page_token());
  } while (!one_page && !request.page_token().empty());

  if (ctx.json) {
    *ctx.out << ToJson(all);
    return kExitOk;
  }
  std::ostream& out = *ctx.out;
  out << "ID                STATE      POINTS      VALID GROUND  MEMORY_MB  SOURCE\n";
  for (const v1::Map& map : all.maps()) {
    char line[256];
    std::snprintf(line, sizeof(line), "%-17s %-10s %-11llu %-13llu %-10s ", map.id().c_str(),
                  StateName(map.state()), static_cast<unsigned long long>(map.input_point_count()),
                  static_cast<unsigned long long>(map.valid_ground_point_count()),
                  Megabytes(map.memory_bytes()).c_str());
    out << line << SourceText(map.source()) << "\n";
  }
  if (!all.next_page_token().empty())
    out << "next page: --page-token " << all.next_page_token() << "\n";
  return kExitOk;
}

int Delete(const Context& ctx, Arguments& args) {
  const auto id = args.NextPositional();
  if (!id) throw UsageError("maps delete needs a map id");
  args.Finish();
  v1::DeleteMapRequest request;
  request.set_map_id(*id);
  grpc::ClientContext call;
  client::SetDeadline(&call, ctx.deadline_s);
  v1::DeleteMapResponse response;
  const grpc::Status status = Stub(ctx)->DeleteMap(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "DeleteMap", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
  } else {
    *ctx.out << "deleted map " << *id << "\n";
  }
  return kExitOk;
}

}  // namespace

int RunMaps(const Context& ctx, Arguments& args) {
  const auto verb = args.NextPositional();
  if (!verb) throw UsageError("maps needs a subcommand: create, upload, get, list or delete");
  if (*verb == "create") return Create(ctx, args);
  if (*verb == "upload") return Upload(ctx, args);
  if (*verb == "get") return Get(ctx, args);
  if (*verb == "list") return List(ctx, args);
  if (*verb == "delete") return Delete(ctx, args);
  throw UsageError("unknown maps subcommand \"" + *verb +
                   "\"; use create, upload, get, list or delete");
}

}  // namespace strata::cli
