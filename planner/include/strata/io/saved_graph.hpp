#pragma once
/// Surface graphs saved to a file and loaded instead of built: a kilometre's graph takes
/// seconds to build and a fraction of that to read, and every replica that plans on a map
/// needs one per robot profile.
///
/// The file is framed as a saved model is (strata/io/saved_model.hpp: magic "STRATAGR", format
/// version, writer, payload length, payload, XXH3-64 checksum), and refused alike: not a
/// saved graph, another format version, truncated, corrupted, inconsistent. The payload holds
/// the robot's TraversabilityParams as named fields, the node count, and per node what the
/// model does not give (SurfaceGraph::Parts): clearance, component, rim distance, landmark
/// distances. The nodes themselves are found again from the model, so a graph can only be
/// loaded onto a model that gives as many nodes for those params; that it is the model it was
/// built on is the saver's to ensure (a map store keeps it beside that model).

#include <cstdint>
#include <string>
#include <string_view>

#include "strata/assessment/terrain_model.hpp"
#include "strata/named_file.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/status.hpp"

namespace strata {

/// The format version this build writes and reads; it changes whenever the stored values mean
/// something else, and with the saved model's (a graph is measured on a model).
inline constexpr std::uint32_t kSavedGraphFormatVersion = 1;

/// The first bytes of every saved graph.
inline constexpr std::string_view kSavedGraphMagic = "STRATAGR";

/// The saved graph of `graph`, in memory.
std::string SerializeGraph(const SurfaceGraph& graph);

/// Writes the saved graph of `graph` to `path` atomically (a temporary beside it, renamed).
/// kMapLoadFailed naming the path when it cannot be written.
Status SaveGraph(const SurfaceGraph& graph, const std::string& path);

/// The graph saved in `bytes`, on `model` (which must outlive it); `name` is what messages call
/// it. kMapLoadFailed as the class comment says; kInvalidConfig when the params it holds do
/// not suit the model (SurfaceGraph::Build's refusal).
Expected<SurfaceGraph> DeserializeGraph(std::string_view bytes, const TerrainModel& model,
                                        const std::string& name);

/// The graph saved at `file.path`, on `model`, read in one pass; messages name it `file.name`.
Expected<SurfaceGraph> LoadGraph(const NamedFile& file, const TerrainModel& model);

/// A name for the graph of `params` under this format version: 32 lowercase hex digits (the
/// XXH3-128 of the format versions and every field of `params` by name), equal in every
/// process for equal params. Where graphs are kept by robot (a map store), this names the file.
std::string SavedGraphKey(const TraversabilityParams& params);

}  // namespace strata
