#pragma once
// The JSON schema of Kelvin requests (issue 3), shared by `distlab kelvin` and later the server.
//
// Request:  {"mesh": {"path": FILE} | {"asset": NAME}, "lx": number, "center": [x, y, z]?,
//            "far_radius": number?, "cache": DIR? (the field store, kelvin/store.hpp),
//            "cache_budget": bytes? (with cache: evict least recently used entries down to it),
//            "sigma": {"constant"?, "per_vertex"?: [one per vertex of the file, in its order;
//                      vertices at one position carry one value],
//                      "axis"?: AXIS | [AXIS, ...], "brushes"?: [BRUSH, ...]} (terms add up; brushes
//                      apply in order, "towards" ones move σ towards their value),
//            "query": [[x, y, z], ...]?,
//            "isosurfaces": {"levels": [...], "format": "ply"|"stl"|"obj"|"glb", "path": FILE}?,
//            "components"?: "all"|"largest", "simplify"?: {"faces": N}, "repair"?: "none"|"fix"|"wrap",
//            "repair_options"?: {...}} (ReshapeRequest below)
//            AXIS = {"axis": [x,y,z], "d0", "sigma_nom", "origin"?: [x,y,z], "width"?} (eq. 24)
//            BRUSH = {"center": [x,y,z], "radius", "value", "falloff"?, "mode"?: "add"|"towards"}
// Response: {"stats": {"n_verts", "n_tets", "size_mb", "t_mesh", "t_build", "t_decomp",
//            "t_solve", "cache_hit", "t_load" (hits), "t_wait" (with cache)}, "mesh": {"n_vertices", "n_faces", "n_welded_vertices"},
//            "query": {"h": [...], "gradient": [[...], ...], "inside": [...]},
//            "isosurfaces": [{"level", "path", "n_verts", "n_faces", "digest", "check"}, ...]}.
//            A level the field never takes (at or below its minimum) is an error naming it, and
//            so is a surface that is not a closed 2-manifold (never written). "check": SURFACE_CHECK.
//            SURFACE_CHECK = {"closed", "manifold", "components", "volume", "boundary_edges",
//            "non_manifold_edges", "non_manifold_vertices", "degenerate_faces"}, counted on the
//            surface welded at float32 (mesh/checks.hpp).
//            h and gradient are null where undefined (inside, or V ≤ 0 there).
//            With several levels the files are PATH-stem_<i>.ext, one per level.
// Errors:   {"error": {"code", "message", "field"}} as for GAP.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/geometry/progress.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/store.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/mesh/repair.hpp"
#include "distlab/server/config.hpp"

namespace distlab::server {

// A file's unit, metres per unit: "m", "cm", "mm", "in" (else InvalidInput on `field`).
double unit_scale(const std::string& unit, const std::string& field = "unit");

// SURFACE_CHECK above: what an exported iso-surface is, sent with it.
inline nlohmann::json surface_check_json(const mesh::SurfaceReport& r) {
  return {{"closed", r.closed()}, {"manifold", r.manifold()}, {"components", r.components}, {"volume", r.volume}, {"boundary_edges", r.boundary_edges}, {"non_manifold_edges", r.non_manifold_edges}, {"non_manifold_vertices", r.non_manifold_vertices}, {"degenerate_faces", r.degenerate_faces}};
}

// The CLI's and Python's rule for the mesh worker (PrepareOptions::mesh_worker): only an explicit
// mesh_threads > 1 meshes in its child process; 0 (absent) stays one thread here, the same field
// bit for bit (the service's 0 chooses the threads instead).
inline void use_mesh_worker(kelvin::PrepareOptions& options, const std::string& mesh_worker) {
  if (options.mesh_threads > 1) options.mesh_worker = mesh_worker;
}

// Runs a whole request. Throws InvalidInput (with the field) on bad input. mesh_worker as in
// use_mesh_worker (the CLI's own binary).
nlohmann::json run_kelvin_request(const nlohmann::json& request, const kelvin::Progress& progress = {},
                                  const std::string& mesh_worker = "");

// Parses the "sigma" object (field prefix "sigma").
kelvin::SigmaSpec parse_sigma(const nlohmann::json& j);

// The mesh formats an asset or upload may have (what assimp reads here).
inline constexpr const char* kMeshExtensions[] = {".stl", ".ply", ".obj", ".glb", ".off"};

// Finds a mesh asset by name (field "mesh.asset"): in assets_dir when given (the service), else
// in $DISTLAB_ASSETS, ./assets, or an assets/ folder above the executable.
std::string asset_path(const std::string& name, const std::string& assets_dir = "");

// σ as solved (kelvin::field_sigma) with per_vertex replaced by the user's values carried to a repaired
// surface by to_repaired (mesh::nearest_face_transfer from the user's mesh).
kelvin::SigmaSpec carry_sigma(kelvin::SigmaSpec solved, const kelvin::SigmaSpec& user, const mesh::Transfer& to_repaired);

// "repair": "none" | "fix" | "wrap" and "repair_options" of a request (fix: max_hole_edges; wrap:
// alpha and offset in metres), checked against the limits (InvalidInput naming the field).
struct RepairRequest {
  std::string kind = "none";
  nlohmann::json options = nlohmann::json::object();
};
RepairRequest parse_repair(const nlohmann::json& body, const Limits& limits);
// "simplify": {"faces": N} of a request: N in [4, max_object_triangles]; 0 when absent.
std::size_t parse_simplify(const nlohmann::json& body, const Limits& limits);
// The wrap's bounds from the limits table.
inline mesh::WrapBudget wrap_budget(const Limits& l) {
  return {l.max_repair_faces, static_cast<double>(l.max_repair_bytes) / 1e6, l.max_repair_seconds};
}
// A wrap's predicted faces, megabytes and seconds (mesh::estimate_wrap) with the α and offset it
// would use, for POST /api/kelvin/estimate; none for no wrap.
std::optional<mesh::WrapEstimate> repair_estimate(const mesh::SurfaceMesh& user, const RepairRequest& request);
// A wrap request over the budget, refused before any work (InvalidInput repair_options.alpha).
void require_repair_within(const mesh::SurfaceMesh& user, const RepairRequest& request, const Limits& limits);
// Runs mesh::fix or mesh::wrap on the user's mesh; the result and its report (fix: steps; wrap:
// alpha, offset and the Hausdorff distances; both: n_vertices, n_faces). Cancellable by `progress`.
std::pair<mesh::RepairResult, nlohmann::json> run_repair_request(const mesh::SurfaceMesh& user, const RepairRequest& request,
                                                                 const mesh::WrapBudget& budget, const Progress& progress = {});

// How a request reshapes the user's surface before preparation, in this order: "components":
// "all" (default: one field around every piece) | "largest" (the piece enclosing the largest
// volume; the others are dropped), "simplify", "repair". The service, the CLI, the CBF fields
// and Python read and apply it alike.
struct ReshapeRequest {
  bool largest_piece = false;
  std::size_t simplify_faces = 0;
  RepairRequest repair;
  bool any() const { return largest_piece || simplify_faces > 0 || repair.kind != "none"; }
};
ReshapeRequest parse_reshape(const nlohmann::json& body, const Limits& limits);
struct Reshaped {
  mesh::SurfaceMesh surface;                                         // the surface to prepare (closed: the preparation checks it)
  nlohmann::json components_report, simplify_report, repair_report;  // null where not done
};
// `welded`: mesh::weld(user).surface. The repair is refused up front when over its budget.
Reshaped reshape_surface(const mesh::SurfaceMesh& user, const mesh::SurfaceMesh& welded, const ReshapeRequest& request,
                         const Limits& limits, const Progress& progress = {});

// A rough vertex count of the preparation, for the vertex budget: the exterior mesh has element
// size l_x up to far_radius · R (R: the bounding radius), and beyond it the mesh of the inverted
// ball |y| < 1 / (far_radius · R) has the same order of vertices, so the count grows like
// (far_radius · R / l_x)³ (far_radius below 1 counts as 1). The constant is fitted to the cube
// asset (1608 vertices at l_x 0.2, 11891 at 0.1); measured ratios are in the notes of issue 15.
inline constexpr double kVertexEstimateConstant = 20.0;
// With the graded sizing (grading > 0) its refinement near sharp edges (the server's feature angle,
// PrepareOptions' default) adds kGradedEdgeVerticesPerLength · (their length) / l_x: the volume
// term, eq. 23's, bounds the rest (grading only coarsens away from the edges).
double estimate_vertices(const mesh::SurfaceMesh& surface, double lx, double far_radius = 1.0, double grading = 0.0);
// The grading to estimate with: the requested one, or eq. 23's (0) when prepare chooses, which
// takes the graded sizing only where it predicts at most kAutoGradedShare of eq. 23's vertices.
inline double sizing_for_budget(const kelvin::PrepareOptions& o) { return o.grading.value_or(0.0); }
// The smallest l_x whose estimate fits `budget` vertices (the estimate above solved for l_x);
// +infinity when none does (the surface alone has budget vertices or more).
double smallest_lx_within(const mesh::SurfaceMesh& surface, double budget, double far_radius = 1.0);

// The vertex budget of a preparation (Limits::max_vertex_estimate): one rule for the Kelvin objects
// (POST /api/kelvin/objects, /estimate, a repaired surface in its job) and the CBF scenarios' fields.
//
// The closed form (estimate_vertices) is free and an upper bound, but 3–30× the field's vertices
// (8.5× on the paper's cube at l_x 0.02: 1.62M against 190k made). Within the budget it decides
// alone; over it, the preparation's own prediction (kelvin::predict_preparation, within 1.5× of the
// field's vertices on the assets and wrapped scans: tests/server/test_estimates.cpp) decides, with
// kPredictionMargin for its error. Whatever a prediction misjudges, the mesher stops at the budget
// (PrepareOptions::max_vertices), naming lx.
inline constexpr double kPredictionMargin = 1.5;

struct VertexCount {
  double closed_form = 0;           // estimate_vertices (with the request's grading, far radius)
  std::optional<double> predicted;  // the prediction's field vertices, asked only when closed_form is over
  std::string unpredicted;          // why there is none although it was needed ("" otherwise)
  // What the budget holds the preparation to.
  double count() const;
};

// The preparation's predicted field vertices for these inputs (PreparePrediction::vertices). Throws
// InvalidInput for what the preparation would refuse (passed on, but for lx's: over the budget,
// that is the mesher's own size limit, and the budget's refusal says it) and kelvin::Cancelled when
// its job is cancelled; any other exception means "not predicted" (its message says why: a deadline).
using VertexPredictor = std::function<double(const mesh::SurfaceMesh&, const kelvin::PrepareOptions&)>;

// The count of a preparation with `options` (l_x resolved) whose closed form is `closed_form`;
// `predict` runs on `surface` (the one the preparation prepares) only when the closed form is over
// the budget (null `surface` or `predict`: the closed form alone).
VertexCount count_vertices(double closed_form, const mesh::SurfaceMesh* surface, const kelvin::PrepareOptions& options,
                           const Limits& limits, const VertexPredictor& predict);

// 422 over_budget when count.count() is over max_vertex_estimate, naming `far_field` when the
// request's far radius alone puts it over (the closed form at far radius 1 fits) and `lx_field`
// otherwise, with an l_x that fits: the smallest within the closed form (every l_x from it up is
// accepted without a prediction).
void require_within_budget(const VertexCount& count, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options,
                           const Limits& limits, const std::string& lx_field, const std::string& far_field);

// The field store (kelvin/store.hpp) of the service and the CBF fields: the directory with the
// budget and lease of the limits table (max_cache_bytes, cache_lease_seconds).
inline kelvin::FieldStore field_store(const std::string& dir, const Limits& limits) {
  kelvin::FieldStore store{dir, limits.max_cache_bytes};
  store.lease_seconds = limits.cache_lease_seconds;
  return store;
}
// A store's budget in a request: a whole number of bytes, at least 1 (else InvalidInput on field).
std::uint64_t parse_cache_budget(const nlohmann::json& j, const std::string& field);
// `distlab cache ls | verify | gc` and distlab.cache in Python: one JSON for both (InvalidInput
// "dir" when dir is not a directory).
// ls:     {"dir", "bytes", "entries": [{"name", "bytes", "last_used" (Unix s), "current", "format",
//          and for a current one "lx", "far_radius", "feature_angle", "grading" (null: chosen),
//          "center", "surface_vertices", "surface_faces", "n_verts", "n_tets"}] (most recently
//          used first), "leases": [{"name", "host", "pid", "started", "renewed", "lease_seconds",
//          "state"}], "temporaries": [file names]}
// verify: {"dir", "entries": [{"name", "bytes", "status", "removed"}], "ok", "bad", "removed"}
// gc:     {"dir", "budget" (null: none), "keep_recent_seconds", "bytes_before", "bytes_after",
//          "evicted": [names], "kept_recent", "removed": [file names]}
nlohmann::json cache_ls_json(const std::string& dir);
nlohmann::json cache_verify_json(const std::string& dir, bool fix);
nlohmann::json cache_gc_json(const kelvin::FieldStore& store);

}  // namespace distlab::server
