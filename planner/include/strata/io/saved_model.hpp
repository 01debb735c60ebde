#pragma once
/// Assessed models saved to a file and loaded without assessing again (docs/design.md §2).
///
/// The file: the magic "STRATAMD", the format version (u32), the writer's version string
/// (u32 length + bytes, at most 256), the payload length (u64), the payload, and an XXH3-64
/// checksum (u64) of every byte before it. The payload holds the assessment parameters and
/// summary as named fields (ForEachField), then the surfaces and the fields as arrays, all
/// little-endian. The same model always gives the same bytes.
///
/// Reading refuses, with kMapLoadFailed and a message naming the file and the problem, a file
/// that is not a saved model (no magic), one of another format version (assess the map
/// again), a truncated or corrupted one (the checksum, checked before anything is built), and
/// one whose contents are inconsistent even with a good checksum (every length is checked
/// against the bytes left before anything is allocated, every index and layer against the
/// grid). It never allocates more than the file's size plus a constant.

#include <cstdint>
#include <memory>
#include <string>
#include <string_view>

#include "strata/assessment/terrain_model.hpp"
#include "strata/named_file.hpp"
#include "strata/status.hpp"

namespace strata {

/// The format version this build writes and reads. It changes whenever the stored fields mean
/// something else, layout or not, so no model assessed by another rule is loaded (and a map's
/// version, which hashes it, changes with it). 2: S' leaves cells inside obstacles out.
inline constexpr std::uint32_t kSavedModelFormatVersion = 2;

/// The first bytes of every saved model.
inline constexpr std::string_view kSavedModelMagic = "STRATAMD";

/// Whether `first_bytes` (the start of a file, at least 8 bytes to say yes) is a saved model's.
bool IsSavedModel(std::string_view first_bytes);

/// Whether the file at `path` starts with the saved-model magic (false when it cannot be read).
bool IsSavedModelFile(const std::string& path);

/// The assessment parameters a saved model holds, read from the start of the file without
/// loading the rest (nor checking its checksum): to decide quickly whether a request's
/// parameters agree with the file's. Fails as LoadModel does on the header.
Expected<AssessmentConfig> ReadSavedModelConfig(const NamedFile& file);

/// The saved model of `model`, in memory.
std::string SerializeModel(const TerrainModel& model);

/// Writes the saved model of `model` to `path`, atomically: to a temporary file beside it,
/// then renamed over `path`, so a reader never sees half a file. kMapLoadFailed naming the
/// path when it cannot be written.
Status SaveModel(const TerrainModel& model, const std::string& path);

/// The model saved in `bytes`; `name` is what messages call it (a path).
Expected<std::shared_ptr<const TerrainModel>> DeserializeModel(std::string_view bytes,
                                                               const std::string& name);

/// The model saved at `file.path`, read in one pass (memory: the model, not the file twice);
/// messages name it `file.name`.
Expected<std::shared_ptr<const TerrainModel>> LoadModel(const NamedFile& file);

}  // namespace strata
