// `strata maps create|upload|get|list|delete`.
#include <chrono>
#include <cmath>
#include <numbers>
#include <optional>
#include <thread>
#include <tuple>

#include <fmt/format.h>

#include "commands.hpp"
#include "connection.hpp"
#include "output.hpp"
#include "point_file.hpp"
#include "strata/client/rpc.hpp"
#include "strata/v1/map_service.grpc.pb.h"

namespace strata::cli {
namespace {

// At most 1 MiB of whole 12-byte points per chunk (map_service.proto PointChunk).
constexpr std::size_t kMaxChunkPoints = (1 << 20) / 12;
// How often --wait asks after a CREATING map.
constexpr auto kWaitPollPeriod = std::chrono::milliseconds(250);

std::unique_ptr<v1::MapService::Stub> Stub(const Context& ctx) {
  return v1::MapService::NewStub(OpenChannel(ctx));
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
    // NAME:SEED[:size_m=M][:spacing_m=M], as strata-offline takes it after "scene:".
    const v1::SceneSource& scene = source.scene();
    std::string text = fmt::format("scene {}:{}", scene.name(), scene.seed());
    if (scene.has_size_m()) text += ":size_m=" + JsonNumber(scene.size_m());
    if (scene.has_spacing_m()) text += ":spacing_m=" + JsonNumber(scene.spacing_m());
    return text;
  }
  if (source.has_upload()) return fmt::format("upload {} B", source.upload().received_bytes());
  return "-";
}

// Memory in MiB, as the web viewer shows it: one figure, one unit.
std::string Mebibytes(std::uint64_t bytes) {
  return Fixed(static_cast<double>(bytes) / 1048576.0, 1);
}

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
    out << "  memory      " << Mebibytes(map.memory_bytes())
        << " MiB (terrain model and the robot graphs cached so far)\n";
    out << "  assessment  " << Fixed(map.assessment_seconds().total_s(), 2) << " s (load "
        << Fixed(map.assessment_seconds().load_s(), 2) << " s)\n";
  }
}

// --wait: asks after `map` until it leaves CREATING, printing a line on stderr whenever its
// step or whole percent changes, so that a site that takes minutes shows how far it has come
// (the request's own `wait` would say nothing until the end). Gives up at the deadline,
// counted from `started`; the assessment goes on on the server.
int WaitUntilCreated(const Context& ctx, std::chrono::steady_clock::time_point started,
                     v1::Map* map) {
  const auto deadline = started + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                      std::chrono::duration<double>(ctx.deadline_s));
  auto stub = Stub(ctx);
  std::string shown;
  while (map->state() == v1::MAP_STATE_CREATING) {
    const std::string line = "map " + map->id() + ": CREATING, " +
                             (map->assessment_step().empty() ? "queued" : map->assessment_step()) +
                             ", " + Fixed(100 * map->progress(), 0) + "% done";
    if (line != shown) *ctx.err << line << "\n" << std::flush;
    shown = line;
    if (std::chrono::steady_clock::now() + kWaitPollPeriod > deadline) {
      *ctx.err << "strata: map " << map->id() << " is still CREATING after --deadline "
               << JsonNumber(ctx.deadline_s) << " s; it goes on on the server (strata maps get "
               << map->id() << ")\n";
      return kExitRpcError;
    }
    std::this_thread::sleep_for(kWaitPollPeriod);
    v1::GetMapRequest request;
    request.set_map_id(map->id());
    grpc::ClientContext call;
    PrepareCall(ctx, &call,
                std::chrono::duration<double>(deadline - std::chrono::steady_clock::now()).count());
    const grpc::Status status = stub->GetMap(&call, request, map);
    if (!status.ok()) return ReportRpcError(ctx, "GetMap", status);
  }
  return kExitOk;
}

// TerrainParameters (proto/strata/v1/common.proto), shared by create and upload; unset ones
// take the server's defaults.
struct TerrainFlags {
  std::optional<double> resolution_m;
  std::optional<double> ground_radius_m;
  std::optional<double> max_tilt_rad;
  std::optional<double> height_tolerance_m;
  std::optional<double> padding_m;
};

void AddTerrainFlags(CLI::App& command, TerrainFlags* terrain) {
  auto add = [&command](const char* name, std::optional<double>* value, const char* unit,
                        const char* help) {
    command.add_option(name, *value, help)
        ->type_name(unit)
        ->check(FiniteNumber())
        ->group("Terrain (TerrainParameters; unset: the server's default)");
  };
  add("--resolution", &terrain->resolution_m, "M", "edge of a grid cell");
  add("--ground-radius", &terrain->ground_radius_m, "M", "Valid Ground Filter radius");
  add("--max-tilt", &terrain->max_tilt_rad, "RAD", "steepest slope a robot may stand on");
  add("--height-tolerance", &terrain->height_tolerance_m, "M",
      "rise the Valid Ground Filter ignores as sensor noise");
  add("--padding", &terrain->padding_m, "M", "margin added around the cloud's bounds");
}

void SetTerrain(const TerrainFlags& flags, v1::TerrainParameters* terrain) {
  if (flags.resolution_m) terrain->set_resolution_m(*flags.resolution_m);
  if (flags.ground_radius_m) terrain->set_ground_radius_m(*flags.ground_radius_m);
  if (flags.max_tilt_rad) terrain->set_max_tilt_rad(*flags.max_tilt_rad);
  if (flags.height_tolerance_m) terrain->set_height_tolerance_m(*flags.height_tolerance_m);
  if (flags.padding_m) terrain->set_padding_m(*flags.padding_m);
}

struct CreateFlags {
  std::string id;
  std::optional<std::string> file;
  std::optional<std::string> scene;
  std::optional<long long> seed;
  std::optional<double> size_m;
  std::optional<double> spacing_m;
  TerrainFlags terrain;
  bool wait = false;
};

int Create(const Context& ctx, const CreateFlags& flags) {
  v1::CreateMapRequest request;
  request.set_map_id(flags.id);
  if (flags.file) request.mutable_file()->set_path(*flags.file);
  if (flags.scene) {
    // Only what was given: the server fills in the scene's defaults.
    v1::SceneSource* scene = request.mutable_scene();
    scene->set_name(*flags.scene);
    if (flags.seed) scene->set_seed(static_cast<std::uint32_t>(*flags.seed));
    if (flags.size_m) scene->set_size_m(*flags.size_m);
    if (flags.spacing_m) scene->set_spacing_m(*flags.spacing_m);
  }
  SetTerrain(flags.terrain, request.mutable_terrain());

  const auto started = std::chrono::steady_clock::now();
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::Map map;
  const grpc::Status status = Stub(ctx)->CreateMap(&call, request, &map);
  if (!status.ok()) return ReportRpcError(ctx, "CreateMap", status);
  if (flags.wait) {
    if (const int code = WaitUntilCreated(ctx, started, &map); code != kExitOk) return code;
  }
  PrintMap(ctx, map);
  return kExitOk;
}

struct UploadFlags {
  std::string id;
  std::string path;
  std::optional<std::string> format;
  std::size_t chunk_points = kMaxChunkPoints;
  TerrainFlags terrain;
  bool wait = false;
};

int Upload(const Context& ctx, const UploadFlags& flags) {
  const std::string& path = flags.path;
  const std::optional<PointFileFormat> format =
      flags.format ? ParsePointFileFormat(*flags.format) : GuessPointFileFormat(path);
  if (!format) {
    throw UsageError("cannot tell the format of \"" + path +
                     "\" from its extension; give --format pcd, xyz or raw");
  }
  v1::UploadMapRequest header;
  header.mutable_header()->set_map_id(flags.id);
  header.mutable_header()->set_format(v1::POINT_FORMAT_XYZ_F32_LE);
  SetTerrain(flags.terrain, header.mutable_header()->mutable_terrain());

  PointFileReader reader(path, *format);  // Throws before any call for an unusable file.
  header.mutable_header()->set_point_count(reader.point_count());

  const auto started = std::chrono::steady_clock::now();
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::Map map;
  auto stream = Stub(ctx)->UploadMap(&call, &map);
  bool sending = stream->Write(header);
  v1::UploadMapRequest chunk;
  std::string* points = chunk.mutable_chunk()->mutable_points();
  // A failed Write means the server ended the call; Finish() then has its status.
  try {
    while (sending && reader.Next(flags.chunk_points, points)) sending = stream->Write(chunk);
  } catch (const UsageError&) {
    call.TryCancel();  // A malformed file part-way: abandon the upload, then report the file.
    stream->Finish();
    throw;
  }
  if (sending) stream->WritesDone();
  const grpc::Status status = stream->Finish();
  if (!status.ok()) return ReportRpcError(ctx, "UploadMap", status);
  if (flags.wait) {
    if (const int code = WaitUntilCreated(ctx, started, &map); code != kExitOk) return code;
  }
  PrintMap(ctx, map);
  return kExitOk;
}

int Get(const Context& ctx, const std::string& id) {
  v1::GetMapRequest request;
  request.set_map_id(id);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::Map map;
  const grpc::Status status = Stub(ctx)->GetMap(&call, request, &map);
  if (!status.ok()) return ReportRpcError(ctx, "GetMap", status);
  PrintMap(ctx, map);
  return kExitOk;
}

struct ListFlags {
  std::optional<int> page_size;
  std::optional<std::string> page_token;
};

int List(const Context& ctx, const ListFlags& flags) {
  const auto& [page_size, page_token] = flags;
  // With --page-size or --page-token: that one page. Otherwise every page, merged.
  const bool one_page = page_size.has_value() || page_token.has_value();
  auto stub = Stub(ctx);
  v1::ListMapsRequest request;
  request.set_page_size(page_size.value_or(0));
  request.set_page_token(page_token.value_or(""));
  v1::ListMapsResponse all;
  do {
    grpc::ClientContext call;
    PrepareCall(ctx, &call);
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
  out << "ID                STATE      POINTS      VALID GROUND  MEMORY_MIB SOURCE\n";
  for (const v1::Map& map : all.maps()) {
    // Map ids are ASCII (the server checks them), so the widths count bytes.
    out << fmt::format("{:<17} {:<10} {:<11} {:<13} {:<10} ", map.id(), StateName(map.state()),
                       map.input_point_count(), map.valid_ground_point_count(),
                       Mebibytes(map.memory_bytes()))
        << SourceText(map.source()) << "\n";
  }
  if (!all.next_page_token().empty())
    out << "next page: --page-token " << all.next_page_token() << "\n";
  return kExitOk;
}

int Delete(const Context& ctx, const std::string& id) {
  v1::DeleteMapRequest request;
  request.set_map_id(id);
  grpc::ClientContext call;
  PrepareCall(ctx, &call);
  v1::DeleteMapResponse response;
  const grpc::Status status = Stub(ctx)->DeleteMap(&call, request, &response);
  if (!status.ok()) return ReportRpcError(ctx, "DeleteMap", status);
  if (ctx.json) {
    *ctx.out << ToJson(response);
  } else {
    *ctx.out << "deleted map " << id << "\n";
  }
  return kExitOk;
}

}  // namespace

void AddMapsCommands(CLI::App& app, const Context& ctx, Command* run) {
  CLI::App* maps = app.add_subcommand("maps", "create, upload, inspect and delete maps");

  auto [create, create_flags] = AddCommand<CreateFlags>(
      *maps, "create",
      "CreateMap from a file under the server's --map-root or a built-in scene (docs/scenes.md)",
      run, [&ctx](const CreateFlags& flags) { return Create(ctx, flags); });
  create->add_option("ID", create_flags->id, "map id; without one the server picks it");
  CLI::App* source = create->add_option_group("Source", "one of --file and --scene");
  CLI::Option* scene =
      source->add_option("--scene", create_flags->scene, "built-in scene")->type_name("NAME");
  source->add_option("--file", create_flags->file, "point cloud under the server's --map-root")
      ->type_name("PATH");
  source->require_option(1);
  create
      ->add_option("--seed", create_flags->seed,
                   "the scene's seed; unset: the server's default (1)")
      ->type_name("N")
      ->check(CLI::Range(0LL, 4294967295LL).description(""))
      ->needs(scene);
  const std::tuple<const char*, std::optional<double>*, const char*> scene_options[] = {
      {"--size", &create_flags->size_m,
       "side of a scene with a size parameter (outdoor_site: 40 to 1000; unset: 100)"},
      {"--spacing", &create_flags->spacing_m,
       "spacing of the scene's points, >= 0.01; unset: the scene's own"}};
  for (const auto& [name, value, help] : scene_options) {
    create->add_option(name, *value, help)->type_name("M")->check(FiniteNumber())->needs(scene);
  }
  AddTerrainFlags(*create, &create_flags->terrain);
  create->add_flag("--wait", create_flags->wait,
                   "return once the map is ACTIVE or FAILED, showing its progress on stderr");

  auto [upload, upload_flags] = AddCommand<UploadFlags>(
      *maps, "upload", "UploadMap: streams a local point cloud in chunks of at most 1 MiB", run,
      [&ctx](const UploadFlags& flags) { return Upload(ctx, flags); });
  upload->add_option("ID", upload_flags->id, "map id")->required();
  upload->add_option("FILE", upload_flags->path, "the point cloud")->required();
  upload
      ->add_option("--format", upload_flags->format,
                   "pcd, xyz (text) or raw (float32 x, y, z); default: from the extension")
      ->type_name("FORMAT")
      ->check(CLI::IsMember({"pcd", "xyz", "raw"}).description(""));
  upload->add_option("--chunk-points", upload_flags->chunk_points, "points per chunk")
      ->type_name("N")
      ->check(CLI::Range(std::size_t{1}, kMaxChunkPoints).description(""))
      ->capture_default_str();
  AddTerrainFlags(*upload, &upload_flags->terrain);
  upload->add_flag("--wait", upload_flags->wait,
                   "return once the map is ACTIVE or FAILED, showing its progress on stderr");

  auto [get, get_id] = AddCommand<std::string>(
      *maps, "get", "GetMap", run, [&ctx](const std::string& id) { return Get(ctx, id); });
  get->add_option("ID", *get_id, "map id")->required();

  auto [list, list_flags] =
      AddCommand<ListFlags>(*maps, "list", "ListMaps: every page merged, or the page asked for",
                            run, [&ctx](const ListFlags& flags) { return List(ctx, flags); });
  list->add_option("--page-size", list_flags->page_size, "maps on one page")
      ->type_name("N")
      ->check(CLI::Range(0, 1000).description(""));
  list->add_option("--page-token", list_flags->page_token, "the page to show")->type_name("T");

  auto [remove, remove_id] = AddCommand<std::string>(
      *maps, "delete", "DeleteMap", run, [&ctx](const std::string& id) { return Delete(ctx, id); });
  remove->add_option("ID", *remove_id, "map id")->required();
}

}  // namespace strata::cli
