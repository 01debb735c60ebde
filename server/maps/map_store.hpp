#pragma once
/// Every map as immutable versions in one directory (--map-store DIR) that several
/// strata-server processes share, on one machine or, in Kubernetes, on a ReadWriteMany volume
/// (possibly NFS). No gRPC here: tests link it without a server.
///
/// Layout under the root:
///
///   strata-map-store            marker: "strata map store, layout 3"; Open refuses another
///                               (a store of layout 1 or 2 is taken over: its versions read
///                               as before)
///   writing                     empty; flock'ed shared by each process while it writes a
///                               terrain, a version or a head, and tried exclusively by the
///                               removers, which delete nothing while a write is in flight
///   maps/<id>/head              the map's kept versions, newest (current) first, one per
///                               line; replaced whole (temporary + rename). A map exists
///                               exactly when its head does.
///   maps/<id>/lock              empty; flock'ed by whoever changes the head or deletes the map
///   maps/<id>/terrains/<t>/     one terrain: what assessing a cloud made, never changed once
///                               renamed into place, shared by every version made of it:
///       tiles                   the list of its cloud's and model's tiles (stored_tiles.hpp;
///                               no cloud tiles for a map made from a saved model). A layout-2
///                               terrain holds cloud.pcd and model.stratamodel instead
///   maps/<id>/tiles/<name>      the tiles of the map's terrains, each once, named by its
///                               content (XXH3-128): a terrain an edit made shares every tile
///                               of its base that the edit left as it was; a tile goes when
///                               no terrain lists it any more
///   maps/<id>/graphs/<t>/       robots' surface graphs built on terrain <t>, one file each
///                               (<key>.stratagraph, strata/io/saved_graph.hpp), put by
///                               whichever replica built one first and loaded by the others
///                               instead of building; removed with the terrain
///   maps/<id>/versions/<v>/     one version, never changed once renamed into place:
///       terrain                 the name <t> of its terrain, and a newline
///       metadata                the caller's bytes (the server's Map message as JSON)
///   tmp/                        temporaries (a version or terrain being written, a head being
///                               replaced), named <kind>.<pid>.<random>
///   trash/                      deleted maps, pruned versions and terrains, renamed here (the
///                               moment they are gone for everyone) and then removed
///
/// <t> is TerrainOf() (or TerrainOfSavedModel()), <v> is VersionOf(): 32 lowercase hex digits
/// naming the content, so replicas that assess the same thing write the same terrain and
/// version (the second writer finds it there and is done). A version that differs from its
/// parent in keep-out zones alone (metadata) names the parent's terrain: it costs two small
/// files. A layout-1 version holds cloud.pcd and model.stratamodel itself, and reads as before.
///
/// What it relies on, and nothing else (no mmap, no O_DIRECT, no hard links):
/// - rename(2) of a file or a directory within one file system is atomic, and fails on a
///   non-empty directory: a version appears complete or not at all, a head is old or new;
/// - open(O_CREAT | O_EXCL) and mkdir(2) fail when the name exists (unique temporaries);
/// - flock(2) excludes other processes and hosts. Linux's NFS client implements it with
///   NFS byte-range locks (NFSv4, or NLM for v3); a mount with `nolock` or
///   `local_lock=flock|all` breaks the exclusion between hosts. Threads of one process are
///   serialised by a process-wide mutex per map as well, whatever the mount;
/// - fsync(2) on files and directories makes what was written durable before the rename that
///   publishes it;
/// - NFS close-to-open consistency: a reader that opens a head after it was replaced sees
///   the new one, once the client's cached view of the directory expires (the mount's
///   acdirmax / lookupcache, 60 s by default). That bounds how late another host sees a new
///   version or a deletion.
///
/// Tiles are made durable (an fsync each when they are few, as an edit's; one syncfs(2) for
/// a new map's thousands) and the tiles directory synced before the terrain listing them is
/// renamed into place. A terrain's tiles are checked to be there,
/// and a missing one written again, under the map's lock, which collecting tiles takes too: no
/// terrain is renamed into place listing a tile that is not there.
///
/// A process killed at any point leaves at most a temporary in tmp/ (removed by the next
/// Open or CollectGarbage once older than kStaleTemporaryAge), a version directory no head
/// lists or a terrain no version names (same), or a map directory without a head (same):
/// never something a reader takes for a version or a map, or tiles no terrain lists (collected
/// with the next terrain the map loses, or by CollectGarbage). A terrain is removed with the
/// last version that names it.
///
/// Thread-safe: any number of threads and MapStore objects (in this process or others) may
/// use one root at once.
#include <chrono>
#include <condition_variable>
#include <deque>
#include <filesystem>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "common/service_error.hpp"
#include "maps/map_heads.hpp"
#include "maps/map_root.hpp"
#include "maps/store_files.hpp"
#include "maps/stored_tiles.hpp"
#include "strata/assessment/terrain_config.hpp"
#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/point_cloud.hpp"
#include "strata/prism.hpp"

namespace strata::server {

/// How old a temporary, an unlisted version or a map without a head must be before Open and
/// CollectGarbage remove it as a dead writer's leftover. Writing a version takes seconds; an
/// hour also covers clock skew between the hosts that share an NFS volume (the age is the
/// file server's modification time against this host's clock).
inline constexpr std::chrono::hours kStaleTemporaryAge{1};

/// The files of a version, opened for an edit. Whole files are read whole even if the version
/// is pruned meanwhile; tiles go when no kept terrain lists them, so a version pruned while its
/// tiles are read fails with kMapVersionNotFound (ReadTiles).
struct VersionFiles {
  /// A terrain of layout 1 or 2: its cloud and model files. Null for a tiled terrain.
  std::shared_ptr<const OpenedMapFile> cloud;
  std::shared_ptr<const OpenedMapFile> model;
  /// A tiled terrain (layout 3): the map's tiles directory and the terrain's list.
  std::optional<OpenedTiles> tiles;
};

class MapStore {
 public:
  /// The terrain that `cloud` assessed with `config` makes, by name: the XXH3-128 (lowercase
  /// hex, 32 digits) of the saved-model format version, the points' float bytes in order and
  /// every assessment parameter by name except num_threads (how to assess, not what: the rule
  /// of FirstDifference in strata/assessment/terrain_config.hpp). Equal inputs give equal
  /// names in any process.
  static std::string TerrainOf(const PointCloud& cloud, const AssessmentConfig& config);

  /// The terrain of an edit made from tiles (EditTiledTerrain), by name: the XXH3-128 of the
  /// saved-model format version, the names of the cloud's tiles in order (their contents'
  /// hashes, so the cloud as the tiles hold it) and the parameters as TerrainOf hashes them.
  /// Not TerrainOf of the same cloud: such an edit never holds the whole cloud.
  static std::string TerrainOfTiles(std::span<const std::string> cloud_tiles,
                                    const AssessmentConfig& config);

  /// The terrain of a map loaded from a saved-model file: the XXH3-128 of the file's bytes
  /// (which hold its format version and parameters), in the same form as TerrainOf's.
  static std::string TerrainOfSavedModel(const std::string& path);

  /// The version made of `terrain` with `keep_out` zones marked: the terrain's own name when
  /// there are none (a map's first version is named as its terrain), else the XXH3-128 of the
  /// terrain's name and each zone's corners and height range, in order.
  static std::string VersionOf(std::string_view terrain, std::span<const Prism> keep_out);
  /// VersionOf(TerrainOf(cloud, config), keep_out).
  static std::string VersionOf(const PointCloud& cloud, const AssessmentConfig& config,
                               std::span<const Prism> keep_out);

  /// Whether `version` is a well-formed version name (what VersionOf returns).
  static bool IsVersion(std::string_view version);

  /// The store at `root`, created (with its layout) when absent; removes dead writers'
  /// leftovers (CollectGarbage). kInvalidConfig when `root` is empty, not a directory, not
  /// writable, refuses locks (an NFS mount without lock support), or holds another layout.
  /// With `heads` (etcd), the maps' heads live there instead of in maps/<id>/head: publishing
  /// and deleting are compare-and-swaps on them, reads take what `heads` knows (no file read,
  /// no flock), and a version no shared head lists is a leftover like any other.
  static Result<std::unique_ptr<MapStore>> Open(std::filesystem::path root,
                                                std::shared_ptr<MapHeads> heads = nullptr);

  MapStore(const MapStore&) = delete;
  MapStore& operator=(const MapStore&) = delete;
  /// Waits for the removal of what was discarded to finish (what is left stays in trash/ for
  /// the next Open).
  ~MapStore();

  /// The store's directory (absolute, symbolic links resolved).
  const std::filesystem::path& root() const { return root_; }

  /// Writes terrain `terrain` of map `id` from `cut` (CutIntoTiles of its model and cloud; a
  /// cloud left empty, for a map made from a saved model, makes LoadCloud fail with
  /// kEditNeedsCloud): the tiles it holds that the map does not hold yet are written and made
  /// durable; then the terrain's list of them goes to a fresh temporary directory, made durable
  /// and renamed into place. When the terrain is there already (another writer put it, or an
  /// earlier version is made of it), that is success and nothing is written. `writes` (may be
  /// null) gets what it cost.
  /// The tiles `cut` names without holding them are an edit's base's (BaseTiles): when one is
  /// gone (collected since the edit read its base, which was pruned meanwhile), kMapChanged
  /// naming it, and the terrain is not put: the edit is made again on the current version.
  /// kInvalidInput for a bad id or name, kMapStoreUnavailable when the store cannot be
  /// written (naming the path and the reason).
  ServiceStatus PutTerrain(const std::string& id, const std::string& terrain, const CutTerrain& cut,
                           TileWrites* writes = nullptr);

  /// Keeps `graph`, built on terrain `terrain` of map `id`, for every replica that plans on it
  /// (maps/<id>/graphs/<terrain>/<SavedGraphKey>.stratagraph): written to a temporary, made
  /// durable and renamed over whatever is there (the same graph, or one that no longer loads).
  /// The graphs of a terrain go with it. kInvalidInput for a bad id or name,
  /// kMapStoreUnavailable (naming the path and the reason).
  ServiceStatus PutGraph(const std::string& id, const std::string& terrain,
                         const SurfaceGraph& graph);

  /// Whether a graph for `params` is kept with terrain `terrain` of map `id` (a bad id or
  /// name holds none). Does not load it.
  bool HasGraph(const std::string& id, const std::string& terrain,
                const TraversabilityParams& params) const;

  /// The graph for `params` kept with terrain `terrain` of map `id`, loaded onto `model` (that
  /// terrain's model, which must outlive it); nullopt when none is kept. kMapCorrupted naming
  /// the file when one is kept but does not load (then build it and PutGraph it again).
  Result<std::optional<SurfaceGraph>> LoadGraph(const std::string& id, const std::string& terrain,
                                                const TerrainModel& model,
                                                const TraversabilityParams& params) const;

  /// Whether terrain `terrain` of map `id` is in the store (PutTerrain need not be called).
  bool HasTerrain(const std::string& id, const std::string& terrain) const;

  /// Writes version `version` of map `id`, made of terrain `terrain` (put before) and
  /// `metadata`, as PutTerrain writes a terrain. Does not publish: PublishNew or PublishUpdate
  /// makes it the map's current version. kMapVersionNotFound when the terrain is not in the
  /// store (pruned since: put it again), kInvalidInput, kMapStoreUnavailable.
  ServiceStatus PutVersion(const std::string& id, const std::string& version,
                           const std::string& terrain, const std::string& metadata);

  /// Creates map `id` with `version` (put before) as its only version. Success also when the
  /// map exists with `version` current (another replica created the same map). Fails with
  /// kMapAlreadyExists (naming the current version) when its current version is another,
  /// kMapVersionNotFound when `version` was not put (or the map was deleted since: put it
  /// again), kInvalidInput, kMapCorrupted (an unreadable head), kMapStoreUnavailable.
  ServiceStatus PublishNew(const std::string& id, const std::string& version);

  /// Makes `version` (put before) the current version of `id` if the current one is still
  /// `expected_current` (compare-and-swap), keeping the newest `keep_versions` (>= 1) in the
  /// head and deleting the directories of those dropped. Success also when `version` is
  /// current already (another replica made the same edit). Fails with kMapChanged (naming the
  /// current version: read it and redo the edit) when the current is another, and then
  /// removes `version`'s directory unless the head lists it (a lost race leaves nothing behind
  /// that no head lists; put it again to retry); kMapNotFound,
  /// kMapVersionNotFound when `version` was not put, kInvalidInput (bad names,
  /// keep_versions < 1), kMapCorrupted, kMapStoreUnavailable.
  ServiceStatus PublishUpdate(const std::string& id, const std::string& expected_current,
                              const std::string& version, int keep_versions);

  /// The kept versions of `id`, newest (current) first. kMapNotFound, kInvalidInput (bad id),
  /// kMapCorrupted (a head that is not a list of versions), kMapStoreUnavailable.
  Result<std::vector<std::string>> Versions(const std::string& id) const;

  /// The current version of `id`; fails as Versions does.
  Result<std::string> Current(const std::string& id) const;

  /// The saved model of a version. kMapVersionNotFound naming the id, the version and the
  /// kept ones when the version is not in the store (pruned, never put); kMapNotFound when
  /// the map is not; kMapCorrupted naming the file when it fails to load (truncated, bad
  /// checksum, another format version); kInvalidInput for a bad id or version name. With
  /// `held` (the model of `held_version` of the same map, which the caller holds; may be
  /// null), the tiles both versions list are taken from it: a replica reads only what an
  /// edit changed. `changed_from_held` (may be null) is then set to the columns where the
  /// model may differ from `held` (LoadTiledModel), and left empty when the two versions'
  /// tiles cannot be compared.
  Result<std::shared_ptr<const TerrainModel>> LoadModel(
      const std::string& id, const std::string& version,
      const std::shared_ptr<const TerrainModel>& held = nullptr,
      const std::string& held_version = {},
      std::optional<CellBox>* changed_from_held = nullptr) const;

  /// The source cloud of a version; fails as LoadModel does.
  Result<PointCloud> LoadCloud(const std::string& id, const std::string& version) const;

  /// The files an edit of a version reads, opened; kEditNeedsCloud for a map made from a
  /// saved model; fails as LoadModel does.
  Result<VersionFiles> OpenVersion(const std::string& id, const std::string& version) const;

  /// The terrain version `version` of `id` is made of, or empty for a version of layout 1
  /// (which holds its cloud and model itself); fails as LoadModel does.
  Result<std::string> TerrainOfVersion(const std::string& id, const std::string& version) const;

  /// The metadata of a version, byte for byte as put; fails as LoadModel does.
  Result<std::string> LoadMetadata(const std::string& id, const std::string& version) const;

  /// Ids of the maps (those with a head) after `after_id` in byte order, at most `max` of
  /// them (all when `max` <= 0). kMapStoreUnavailable when the store cannot be listed.
  Result<std::vector<std::string>> ListIds(const std::string& after_id, int max) const;

  /// Deletes map `id`, every version of it, for everyone at once (its directory is renamed
  /// into trash/, then removed). kMapNotFound, kInvalidInput, kMapStoreUnavailable.
  ServiceStatus Delete(const std::string& id);

  /// Returns once everything discarded so far (pruned versions and terrains, deleted maps,
  /// which are gone for everyone at once and removed from the volume in the background) is
  /// removed from the volume, or left in trash/ for CollectGarbage when it cannot be.
  void WaitForRemovals() const;

  /// Removes dead writers' leftovers older than kStaleTemporaryAge (temporaries, versions no
  /// head lists, map directories without a head) and whatever is in trash/. Best effort:
  /// what cannot be removed now is tried again next time. Returns how many entries it removed.
  int CollectGarbage();

 private:
  MapStore(std::filesystem::path root, std::shared_ptr<MapHeads> heads,
           store_files::Fd writing_shared, store_files::Fd writing_probe);

  // The head after publishing `version` over `kept` (the current head) when it was made on
  // `expected_current`; nullopt when `version` is current already. kMapChanged (discarding
  // the version's directory unless `kept` lists it), kMapVersionNotFound when it was not put.
  // `dropped` gets the versions the new head no longer keeps.
  Result<std::optional<std::vector<std::string>>> UpdatedHead(
      const std::string& id, const std::vector<std::string>& kept,
      const std::string& expected_current, const std::string& version, int keep_versions,
      std::vector<std::string>* dropped) const;
  // PublishNew, PublishUpdate and Delete on shared heads: read, decide, compare-and-swap,
  // again when another replica swapped first.
  ServiceStatus PublishNewShared(const std::string& id, const std::string& version);
  ServiceStatus PublishUpdateShared(const std::string& id, const std::string& expected_current,
                                    const std::string& version, int keep_versions);
  ServiceStatus DeleteShared(const std::string& id);
  // CollectGarbage's pass over the maps whose heads are files (under each map's lock).
  int CollectFileHeadGarbage();
  // CollectGarbage's pass over the maps on shared heads (no lock: only leftovers older than
  // kStaleTemporaryAge go, which no publisher still holds).
  int CollectSharedGarbage();

  std::filesystem::path MapDir(const std::string& id) const;
  std::filesystem::path VersionDir(const std::string& id, const std::string& version) const;
  std::filesystem::path TerrainDir(const std::string& id, const std::string& terrain) const;
  std::filesystem::path GraphsDir(const std::string& id, const std::string& terrain) const;
  /// Whether `version` of `id` was put whole: its directory, and the terrain it names.
  bool IsPut(const std::string& id, const std::string& version) const;
  /// Discards the directories of `versions` of `id`, then the terrains they named that no
  /// version left names. Returns how many directories it removed.
  int DiscardVersions(const std::string& id, const std::vector<std::string>& versions) const;
  /// Discards the terrains of `id` that no version names and that are older than
  /// kStaleTemporaryAge (a dead writer's, or one a writer is about to name: not yet stale).
  int DiscardStaleTerrains(const std::string& id) const;
  /// The tiles of the terrain `version` of `id` is made of, nullopt for a version whose terrain
  /// keeps whole files (layouts 1 and 2); fails as LoadModel does.
  Result<std::optional<TerrainTiles>> TilesOfVersion(const std::string& id,
                                                     const std::string& version) const;
  /// The tiles of the terrain `version` of `id` is made of, opened; nullopt for a version
  /// whose terrain keeps whole files; fails as LoadModel does.
  Result<std::optional<OpenedTiles>> OpenTiles(const std::string& id,
                                               const std::string& version) const;
  /// `error`, from reading the tiles of `version` of `id`, as the caller reports it: a tile
  /// gone (kMapVersionNotFound from ReadTiles) is MissingVersion when the version was pruned
  /// meanwhile, kMapCorrupted when it is still kept.
  ServiceError TilesFailed(const std::string& id, const std::string& version,
                           ServiceError error) const;
  /// Removes the tiles of `id` that no terrain lists, when the map is still there, taking the
  /// map's lock only to check the terrains put meanwhile and remove. Returns how many it
  /// removed.
  int CollectTiles(const std::string& id) const;
  /// Has the remover collect the tiles of `id` (after a terrain of it was discarded).
  void ScheduleTileCollection(const std::string& id) const;
  /// Why `version` of `id` cannot be read: kMapNotFound or kMapVersionNotFound.
  ServiceError MissingVersion(const std::string& id, const std::string& version) const;
  /// The path of file `name` of an existing version, or why there is none.
  Result<std::filesystem::path> VersionFile(const std::string& id, const std::string& version,
                                            const char* name) const;
  /// Opens file `name` of a version; kEditNeedsCloud for the cloud of a saved model's map.
  Result<std::shared_ptr<const OpenedMapFile>> OpenVersionFile(const std::string& id,
                                                               const std::string& version,
                                                               const char* name) const;
  /// Renames `path` into trash/ (the moment it is gone for everyone) and hands it to the
  /// remover; false when the rename failed.
  bool Discard(const std::filesystem::path& path) const;
  // Removes what Discard renamed into trash/, one path at a time, and collects the tiles of
  // the maps ScheduleTileCollection names, off the caller's thread: unlinking a terrain's
  // hundreds of megabytes takes a tenth of a second, which a publish (a keep-out zone's in
  // milliseconds) should not wait for.
  void RemoveDiscarded() const;
  /// Waits, with discarded_mutex_ held by `lock`, until the store closes, or `ready()` holds
  /// while no write is in flight: no WriteScope open here and none in another process or
  /// MapStore (the `writing` file, which their scopes hold shared).
  void WaitToRemove(std::unique_lock<std::mutex>& lock, const std::function<bool()>& ready) const;
  /// Whether a write of another process or MapStore holds the `writing` file; with
  /// discarded_mutex_ held and no WriteScope open here.
  bool OthersWriting() const;
  // Open while a terrain, a version or a head is written: the removers wait for none to be.
  class WriteScope;

  std::filesystem::path root_;
  std::shared_ptr<MapHeads> shared_heads_;  // Null: heads are files under root_.
  // What Discard renamed into trash/, for the remover (mutable: discarding is no change of
  // what the store holds).
  mutable std::mutex discarded_mutex_;
  mutable std::condition_variable discarded_changed_;
  mutable std::deque<std::filesystem::path> discarded_;
  mutable std::set<std::string> tiles_to_collect_;  // Map ids, for the remover.
  mutable bool removing_ = false;                   // The remover holds one taken from discarded_.
  // Writes in flight (WriteScope), which the remover lets pass: an unlink's journal work
  // beside them made a keep-out zone's fsyncs wait 20-60 ms on a site.
  mutable int writing_ = 0;
  // Two descriptors of the `writing` file: one held shared while writing_ > 0, and the
  // remover's, tried exclusively only while writing_ == 0, so it meets others' locks alone.
  store_files::Fd writing_shared_;
  store_files::Fd writing_probe_;
  bool closing_ = false;  // Guarded by discarded_mutex_.
  // Runs RemoveDiscarded, from the first discard on; guarded by discarded_mutex_.
  mutable std::thread remover_;
};

}  // namespace strata::server
