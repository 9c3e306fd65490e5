#pragma once
// Kelvin objects of the service. The σ-independent preparation (meshing, assembly, factor) is
// shared by every session through a registry keyed by content (and backed by the on-disk cache);
// σ, the watched iso-levels and everything else a client edits live in its own KelvinObject.
// A shared Field is solved for one σ at a time: readers take a shared lock when the field holds
// their σ already, otherwise an exclusive lock re-solves it (so two sessions never see each
// other's σ, only, at worst, each other's solve time).
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <shared_mutex>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/geometry/types.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/stages.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/lifecycle.hpp"
#include "distlab/server/uploads.hpp"

namespace distlab::server {

// Memory of the boundary responses of all live preparations (Limits::max_response_bytes_total).
class ResponseBudget : public std::enable_shared_from_this<ResponseBudget> {
 public:
  explicit ResponseBudget(std::size_t total) : total_(total) {}
  // Holds `bytes` of the budget until destroyed.
  class Share {
   public:
    Share(std::shared_ptr<ResponseBudget> budget, std::size_t bytes) : budget_(std::move(budget)), bytes_(bytes) {}
    ~Share();
    Share(const Share&) = delete;
    Share& operator=(const Share&) = delete;

   private:
    std::shared_ptr<ResponseBudget> budget_;
    std::size_t bytes_;
  };
  // A share of `bytes`, or nullptr if it does not fit beside the shares held.
  std::unique_ptr<Share> take(std::size_t bytes);
  std::size_t used() const;

 private:
  mutable std::mutex mutex_;
  std::size_t total_, used_ = 0;
};

struct PreparedField {
  PreparedField(std::string k, kelvin::Field f) : key(std::move(k)), field(std::move(f)) {}
  const std::string key;
  kelvin::Field field;
  bool cache_hit = false;
  // Wall seconds PreparedRegistry::acquire took to make it: the preparation's stages (load,
  // invert, mesh, build, decomp, response) or, on a cache hit, the load.
  double seconds = 0;
  std::unique_ptr<ResponseBudget::Share> response_share;  // held while field has its boundary response

  // Runs fn(const kelvin::Field&) with `sigma` solved (sigma_key identifies it exactly). Vertex
  // gradients (needed by queries, not by iso-surfaces) are computed only when `gradients` asks.
  template <class Fn>
  auto with_sigma(const kelvin::SigmaSpec& sigma, const std::string& sigma_key, bool gradients, Fn&& fn) {
    {
      std::shared_lock lock(mutex_);
      if (solved_ == sigma_key && (gradients_ || !gradients)) return fn(static_cast<const kelvin::Field&>(field));
    }
    std::unique_lock lock(mutex_);
    if (solved_ != sigma_key || (gradients && !gradients_)) {
      solved_.clear();
      field.set_sigma(sigma, gradients);
      solved_ = sigma_key;
      gradients_ = gradients;
    }
    return fn(static_cast<const kelvin::Field&>(field));
  }
  // Frees the boundary response and its share of the budget (strokes go on with the factor).
  void release_response() {
    std::unique_lock lock(mutex_);
    field.release_boundary_response();
    response_share.reset();
  }
  // The field's work for a later σ edit (kelvin::Field::background_work), taken under the lock;
  // run it without, while this PreparedField lives.
  std::function<void()> background_work() {
    std::shared_lock lock(mutex_);
    return field.background_work();
  }

 private:
  std::shared_mutex mutex_;
  std::string solved_;      // key of the σ in `field`; "" before the first solve
  bool gradients_ = false;  // `field` holds vertex gradients for solved_
};

class PreparedRegistry {
 public:
  // Boundary responses: at most response_bytes each, response_bytes_total together. Prepared
  // through the store (none if store.dir is empty).
  PreparedRegistry(kelvin::FieldStore store, std::size_t response_bytes, std::size_t response_bytes_total)
      : store_(std::move(store)),
        response_bytes_(response_bytes),
        responses_(std::make_shared<ResponseBudget>(response_bytes_total)) {}
  // The prepared field for this content (`key`: kelvin::prepare_key of it, as the object keeps
  // it, so the surface is not hashed again): from memory, else waits for another job preparing
  // the same content, else prepares (through the disk cache) and builds its boundary response if
  // the budgets allow (progress stage "response"; beyond the total, fields no object holds any
  // more give theirs up first). Throws kelvin::Cancelled if progress.cancel becomes true,
  // InvalidInput for a bad surface.
  std::shared_ptr<PreparedField> acquire(const std::string& key, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options,
                                         const kelvin::Progress& progress, bool* from_memory = nullptr);
  // True if acquire would find this content (`key` as there) in memory or being prepared by
  // another job: it then makes no mesh of its own.
  bool in_memory(const std::string& key, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options);
  std::size_t size() const;
  std::size_t response_bytes_used() const { return responses_->used(); }

 private:
  struct Entry {
    mesh::SurfaceMesh surface;
    kelvin::PrepareOptions options;
    std::weak_ptr<PreparedField> field;
    bool preparing = false;
  };
  Entry* find_locked(const std::string& key, const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o);
  // The field in memory for this content, else nullptr with its preparation claimed for the
  // caller (after waiting while another job prepares it, cancellable by progress).
  std::shared_ptr<PreparedField> find_or_claim(const std::string& key, const mesh::SurfaceMesh& s,
                                               const kelvin::PrepareOptions& o, const kelvin::Progress& progress);
  // Ends a claim: records the field made (nullptr: none), keeps it among the recent ones, and
  // forgets the entries nobody holds.
  void release(const std::string& key, const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o,
               const std::shared_ptr<PreparedField>& f);
  // Prepares (through the store) and builds the boundary response if the budgets allow.
  std::shared_ptr<PreparedField> prepare(const std::string& key, const mesh::SurfaceMesh& s, const kelvin::PrepareOptions& o,
                                         const kelvin::Progress& progress);
  std::unique_ptr<ResponseBudget::Share> take_response(std::size_t bytes);

  kelvin::FieldStore store_;
  std::size_t response_bytes_;
  std::shared_ptr<ResponseBudget> responses_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  std::multimap<std::string, Entry> entries_;
  std::vector<std::shared_ptr<PreparedField>> recent_;  // keeps the last few alive when unused
};

// How an object was made (its status' "source"): one of asset, upload and an inline mesh, and the
// preparation's inputs as given (unset: not given) with the l_x they came to.
struct ObjectSource {
  std::string asset, upload;  // the one given, or neither for an inline mesh
  std::optional<Vec3> center;
  std::optional<double> far_radius, grading, lx_fraction;
  double lx = 0;
  long long vertex_estimate = 0;
  std::string repair;  // ReshapeRequest's repair kind
};

// What a running preparation is doing: repairing (or simplifying) the user's mesh first, then
// preparing the field.
enum class PrepareStage { repairing,
                          preparing };

struct KelvinObject {
  std::string id;
  std::string key;  // content key
  ObjectSource source;
  // The mesh as the user gave it (the file's vertices in the file's order, duplicated positions
  // kept): every per-vertex array of the API (σ per_vertex in, σ values and the surface frame
  // out) is indexed like its vertices. The field is prepared on `welded` (mesh/weld.hpp).
  mesh::SurfaceMesh surface;
  mesh::SurfaceMesh welded;
  std::vector<int> to_welded;     // user vertex -> welded vertex (−1: used by no face)
  std::string surface_digest;     // kelvin::surface_digest(surface)
  ClientShare::Reservation held;  // surface's triangles, in its client's share (client_share.hpp)
  // "components", "simplify", "repair" (ReshapeRequest, kelvin_json.hpp): the field is prepared
  // on `repaired` instead of `welded`, and σ per user vertex reaches it by `to_repaired` (the
  // nearest-face rule). Both are set by the preparation job under `mutex` while its stage is
  // repairing, and never change afterwards.
  ReshapeRequest reshape;
  mesh::SurfaceMesh repaired;
  mesh::Transfer to_repaired;
  nlohmann::json repair_report, simplify_report, components_report;
  bool reshaped() const { return reshape.any(); }  // prepared on `repaired`
  // What the preparation job predicted before it prepared (the surface it prepares, its sizing
  // choice; prepare_estimate.hpp), under `mutex`; null until then or if it could not predict.
  nlohmann::json estimate;

  std::mutex mutex;  // guards everything below
  // queued until its job runs, running (in `stage`), then succeeded (the API's "ready"), failed
  // or cancelled; the API's words are object_state_name's.
  Lifecycle state = Lifecycle::queued;
  PrepareStage stage = PrepareStage::preparing;
  std::string job;
  nlohmann::json error;
  std::shared_ptr<PreparedField> prepared;
  bool shared = false;  // the preparation was found in memory (another session or object)
  // Seconds each stage of the preparation took (kelvin::kPrepareStages), when this object's job
  // computed it (not found in memory or the store); stats.t_stages.
  std::optional<kelvin::StageSeconds> stage_seconds;

  kelvin::SigmaSpec sigma;         // as given: per_vertex per user vertex
  kelvin::SigmaSpec field_sigma;   // what the field solves: per_vertex per welded vertex
  std::string sigma_given = "{}";  // σ's JSON as given (SigmaEdit::given), echoed by GET .../sigma
  // Identifies the solved σ in the shared field: the σ as given and the user mesh it is indexed by
  // (objects sharing a preparation may number their vertices differently).
  std::string sigma_key;
  std::uint64_t sigma_version = 0;
  std::chrono::steady_clock::time_point sigma_at{};  // when the last σ edit arrived
  std::vector<double> levels;                        // watched iso-levels: frames are pushed over the WebSocket
  bool computing = false;                            // a frame task is queued or running
  std::uint64_t frames_version = 0;                  // bumped on every σ or levels change
  // The surface geometry goes out once per object (a late joiner gets its own copy); after that
  // a σ version carries only σ per vertex (surface_sigma frame).
  bool surface_sent = false;     // the surface frame was broadcast
  std::int64_t sigma_sent = -1;  // sigma_version of the last σ values broadcast

  bool ready() const { return state == Lifecycle::succeeded && prepared; }  // call with `mutex` held
  nlohmann::json status_json();                                             // locks
};

// The API's word for an object's state: "repairing" or "preparing" (queued or running, by its
// stage), "ready", "failed", "cancelled".
const char* object_state_name(Lifecycle state, PrepareStage stage);

// kelvin::field_sigma for an object repaired or wrapped: per_vertex carried to the
// repaired surface by to_repaired (call with the object's mutex held, after the repair).
kelvin::SigmaSpec field_sigma(const kelvin::SigmaSpec& user, const KelvinObject& object);

// `given`: σ's JSON as given (SigmaEdit::given).
inline std::string sigma_key(const KelvinObject& o, const std::string& given) { return o.surface_digest + given; }

}  // namespace distlab::server
