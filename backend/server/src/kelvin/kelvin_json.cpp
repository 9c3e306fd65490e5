// Kelvin requests as JSON: parse with field paths, prepare/solve/query, encode.
#include "distlab/server/kelvin_json.hpp"
#include "distlab/server/json_fields.hpp"

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <set>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/kelvin_objects.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

void object_with(const json& j, const std::string& field, const std::set<std::string>& keys) {
  if (!j.is_object()) throw InvalidInput(field, (field.empty() ? "request" : field) + " must be an object");
  for (const auto& [k, v] : j.items())
    if (!keys.count(k))  // NOLINTNEXTLINE(performance-inefficient-string-concatenation): the error, once
      throw InvalidInput(field.empty() ? k : field + "." + k, "unknown key \"" + k + "\"");
}

// Lengths and positions of σ terms and preparation options are coordinates (kMaxCoordinate);
// σ values are bounded by kelvin::validate (max_abs_sigma) with their own message.
double number(const json& j, const std::string& field) { return json_number(j, field); }
double length(const json& j, const std::string& field) { return json_number(j, field, kMaxCoordinate); }
Vec3 vec3(const json& j, const std::string& field) { return json_vec3(j, field, kMaxCoordinate); }

std::string text(const json& j, const std::string& field) {
  if (!j.is_string() || j.get<std::string>().empty()) throw InvalidInput(field, field + " must be a non-empty string");
  return j.get<std::string>();
}

kelvin::AxisSigma parse_axis(const json& j, const std::string& f) {
  object_with(j, f, {"axis", "d0", "sigma_nom", "origin", "width"});
  kelvin::AxisSigma a;
  if (!j.contains("axis")) throw InvalidInput(f + ".axis", f + ".axis is required");
  a.axis = vec3(j["axis"], f + ".axis");
  a.d0 = j.contains("d0") ? length(j["d0"], f + ".d0") : 0.0;
  a.sigma_nom = j.contains("sigma_nom") ? number(j["sigma_nom"], f + ".sigma_nom") : 1.0;
  if (j.contains("origin")) a.origin = vec3(j["origin"], f + ".origin");
  if (j.contains("width")) a.width = length(j["width"], f + ".width");
  return a;
}

json nullable(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

}  // namespace

kelvin::SigmaSpec parse_sigma(const json& j) {
  object_with(j, "sigma", {"constant", "per_vertex", "axis", "brushes"});
  kelvin::SigmaSpec s;
  if (j.contains("constant")) s.constant = number(j["constant"], "sigma.constant");
  if (j.contains("per_vertex")) {
    const json& v = j["per_vertex"];
    if (!v.is_array()) throw InvalidInput("sigma.per_vertex", "sigma.per_vertex must be an array of numbers");
    VecX values(static_cast<Eigen::Index>(v.size()));
    for (size_t i = 0; i < v.size(); ++i)
      values[static_cast<Eigen::Index>(i)] = number(v[i], "sigma.per_vertex[" + std::to_string(i) + "]");
    s.per_vertex = values;
  }
  if (j.contains("axis")) {
    const json& a = j["axis"];
    if (a.is_array()) {
      for (size_t i = 0; i < a.size(); ++i) s.axis.push_back(parse_axis(a[i], "sigma.axis[" + std::to_string(i) + "]"));
    } else {
      s.axis.push_back(parse_axis(a, "sigma.axis"));
    }
  }
  if (j.contains("brushes")) {
    const json& b = j["brushes"];
    if (!b.is_array()) throw InvalidInput("sigma.brushes", "sigma.brushes must be an array");
    for (size_t i = 0; i < b.size(); ++i) {
      const std::string f = "sigma.brushes[" + std::to_string(i) + "]";
      object_with(b[i], f, {"center", "radius", "value", "falloff", "mode"});
      kelvin::BrushSigma br;
      if (!b[i].contains("center") || !b[i].contains("radius") || !b[i].contains("value"))
        throw InvalidInput(f, f + " needs center, radius and value");
      br.centre = vec3(b[i]["center"], f + ".center");
      br.radius = length(b[i]["radius"], f + ".radius");
      br.value = number(b[i]["value"], f + ".value");
      if (b[i].contains("falloff")) br.falloff = length(b[i]["falloff"], f + ".falloff");
      if (b[i].contains("mode")) {
        const json& m = b[i]["mode"];
        if (m != "add" && m != "towards") throw InvalidInput(f + ".mode", f + ".mode must be \"add\" or \"towards\"");
        br.towards = m == "towards";
      }
      s.brushes.push_back(br);
    }
  }
  return s;
}

std::string asset_path(const std::string& name, const std::string& assets_dir) {
  for (char c : name)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-')
      throw InvalidInput("mesh.asset", "asset names are letters, digits, '_' and '-'");
  const std::vector<std::string> roots =
      assets_dir.empty() ? data_dir_candidates("DISTLAB_ASSETS", "assets", "assets") : std::vector<std::string>{assets_dir};
  for (const fs::path root : roots)
    for (const char* ext : kMeshExtensions)
      if (fs::is_regular_file(root / (name + ext))) return (root / (name + ext)).string();
  throw InvalidInput("mesh.asset", "unknown asset \"" + name + "\" (looked in $DISTLAB_ASSETS and assets/)");
}

std::uint64_t parse_cache_budget(const json& j, const std::string& field) {
  const double b = number(j, field);
  if (!(b >= 1 && b <= 1e18 && b == std::floor(b))) throw InvalidInput(field, field + " must be a whole number of bytes, at least 1");
  return static_cast<std::uint64_t>(b);
}

namespace {

// A `distlab kelvin` request (kelvin_json.hpp), read and checked.
struct KelvinRun {
  ReshapeRequest reshape;
  std::string path, path_field;  // the mesh file, and the field that named it
  kelvin::PrepareOptions options;
  bool cached = false;  // "cache" given: prepared through the store
  kelvin::FieldStore store;
  kelvin::SigmaSpec sigma;
  std::vector<Vec3> points;
  std::vector<double> levels;
  std::string iso_format, iso_path;
};

// lx, center, far_radius, grading, feature_angle, max_vertices, mesh_threads.
kelvin::PrepareOptions parse_prepare_options(const json& r) {
  if (!r.contains("lx")) throw InvalidInput("lx", "lx is required");
  kelvin::PrepareOptions options;
  options.lx = number(r["lx"], "lx");
  if (r.contains("center")) options.centre = vec3(r["center"], "center");
  if (r.contains("far_radius")) options.far_radius = number(r["far_radius"], "far_radius");
  // Sizing (PrepareOptions::grading, in [0, 1]; 0 is eq. 23); prepare refuses a bad value.
  if (r.contains("grading")) options.grading = number(r["grading"], "grading");  // absent: prepare chooses
  // Sharp-edge threshold (degrees, PrepareOptions::feature_angle); 180: no sharp edges.
  if (r.contains("feature_angle")) options.feature_angle = number(r["feature_angle"], "feature_angle");
  // Meshing vertex budget (default 1,000,000): beyond it the request fails with an "lx" error.
  if (r.contains("max_vertices")) {
    const double mv = number(r["max_vertices"], "max_vertices");
    if (!(mv >= 100 && mv <= 1e8 && mv == std::floor(mv)))
      throw InvalidInput("max_vertices", "max_vertices must be an integer in [100, 1e8]");
    options.max_vertices = static_cast<std::size_t>(mv);
  }
  if (r.contains("mesh_threads")) options.mesh_threads = json_integer(r["mesh_threads"], "mesh_threads", 0, kelvin::kMaxMeshThreads);
  return options;
}

// "isosurfaces": {"levels", "format", "path"}.
void parse_isosurfaces(const json& iso, KelvinRun& run) {
  object_with(iso, "isosurfaces", {"levels", "format", "path"});
  if (!iso.contains("levels") || !iso["levels"].is_array() || iso["levels"].empty())
    throw InvalidInput("isosurfaces.levels", "isosurfaces.levels must be a non-empty array of numbers");
  for (size_t i = 0; i < iso["levels"].size(); ++i)
    run.levels.push_back(number(iso["levels"][i], "isosurfaces.levels[" + std::to_string(i) + "]"));
  run.iso_format = iso.contains("format") ? text(iso["format"], "isosurfaces.format") : "ply";
  if (run.iso_format != "ply" && run.iso_format != "stl" && run.iso_format != "obj" && run.iso_format != "glb")
    throw InvalidInput("isosurfaces.format", "isosurfaces.format must be ply, stl, obj or glb");
  if (!iso.contains("path")) throw InvalidInput("isosurfaces.path", "isosurfaces.path is required");
  run.iso_path = text(iso["path"], "isosurfaces.path");
}

KelvinRun parse_run(const json& r) {
  object_with(r, "", {"mesh", "lx", "center", "far_radius", "grading", "feature_angle", "max_vertices", "mesh_threads", "cache", "cache_budget", "sigma", "query", "isosurfaces", "repair", "repair_options", "simplify", "components", "comment"});
  KelvinRun run;
  run.reshape = parse_reshape(r, Limits{});
  if (!r.contains("mesh")) throw InvalidInput("mesh", "mesh is required");
  const json& m = r["mesh"];
  object_with(m, "mesh", {"path", "asset"});
  if (m.contains("path") == m.contains("asset")) throw InvalidInput("mesh", "mesh needs exactly one of path and asset");
  run.path = m.contains("path") ? text(m["path"], "mesh.path") : asset_path(text(m["asset"], "mesh.asset"));
  run.path_field = m.contains("path") ? "mesh.path" : "mesh.asset";
  run.options = parse_prepare_options(r);
  // The field store (kelvin/store.hpp) and its budget: after writing, least recently used entries
  // go until the entries take at most cache_budget bytes.
  run.cached = r.contains("cache");
  if (run.cached) run.store.dir = text(r["cache"], "cache");
  if (r.contains("cache_budget")) {
    if (!run.cached) throw InvalidInput("cache_budget", "cache_budget needs cache (the store's directory)");
    run.store.budget_bytes = parse_cache_budget(r["cache_budget"], "cache_budget");
  }
  if (r.contains("sigma")) run.sigma = parse_sigma(r["sigma"]);
  if (r.contains("query")) {
    if (!r["query"].is_array()) throw InvalidInput("query", "query must be an array of [x, y, z]");
    for (size_t i = 0; i < r["query"].size(); ++i) run.points.push_back(vec3(r["query"][i], "query[" + std::to_string(i) + "]"));
  }
  if (r.contains("isosurfaces")) parse_isosurfaces(r["isosurfaces"], run);
  return run;
}

json stats_json(const kelvin::Field& field, bool hit, bool cached) {
  const kelvin::Stats& st = field.stats();
  json stats = {{"n_verts", st.n_verts}, {"n_tets", st.n_tets}, {"size_mb", st.size_mb}, {"t_mesh", st.t_mesh}, {"t_build", st.t_build}, {"t_decomp", st.t_decomp}, {"t_solve", st.t_solve}, {"grading", st.grading}, {"mesh_threads", st.mesh_threads}, {"cache_hit", hit}};
  // On a cache hit t_mesh and t_decomp are the original preparation's; t_load is this load.
  if (hit) stats["t_load"] = st.t_load;
  // Waited for another process preparing the same field (its lease) before loading or taking over.
  if (cached) stats["t_wait"] = st.t_wait;
  return stats;
}

json query_json(const kelvin::Field& field, const std::vector<Vec3>& points) {
  json h = json::array(), grad = json::array(), inside = json::array();
  int hint = -1;
  for (const Vec3& x : points) {
    const kelvin::Sample s = field.query(x, &hint);
    h.push_back(nullable(s.h));
    grad.push_back(s.status == kelvin::Status::ok ? vec_json(s.gradient) : json(nullptr));
    inside.push_back(s.status == kelvin::Status::inside);
  }
  return {{"h", h}, {"gradient", grad}, {"inside", inside}};
}

// Writes each level's iso-surface (PATH-stem_<i>.ext when several); a level the field never
// takes, or a surface that is not a closed 2-manifold, is refused naming the level.
json write_isosurfaces(const kelvin::Field& field, const KelvinRun& run) {
  json files = json::array();
  for (size_t i = 0; i < run.levels.size(); ++i) {
    const double level = run.levels[i];
    fs::path file = run.iso_path;
    if (run.levels.size() > 1) file = file.parent_path() / (file.stem().string() + "_" + std::to_string(i) + file.extension().string());
    const mesh::SurfaceMesh iso = field.isosurface(level);
    const std::string field_name = "isosurfaces.levels[" + std::to_string(i) + "]";
    if (iso.faces.rows() == 0)
      throw InvalidInput(field_name, "the field never takes h = " + json(level).dump() + ": its smallest value is h = " +
                                         json(field.minimum()).dump() + ", and {h = level} is empty below it");
    const mesh::SurfaceReport check = mesh::inspect_surface(iso);
    if (!check.manifold())
      throw InvalidInput(field_name, "the iso-surface at h = " + json(level).dump() + " is not a closed 2-manifold (" +
                                         mesh::surface_defects(check) + "); not written");
    mesh::save_mesh(iso, file.string(), run.iso_format, "isosurfaces.format");
    files.push_back({{"level", level}, {"path", file.string()}, {"n_verts", iso.vertices.rows()}, {"n_faces", iso.faces.rows()}, {"digest", kelvin::surface_digest(iso)}, {"check", surface_check_json(check)}});
  }
  return files;
}

}  // namespace

json run_kelvin_request(const json& r, const kelvin::Progress& progress, const std::string& mesh_worker) {
  KelvinRun run = parse_run(r);
  use_mesh_worker(run.options, mesh_worker);
  // The file's vertices in the file's order: σ per_vertex is indexed by them; the field is
  // prepared on the welded surface (mesh/weld.hpp).
  const mesh::SurfaceMesh surface = mesh::load_mesh(run.path, run.path_field);
  const mesh::Welded welded = mesh::weld(surface);
  kelvin::SigmaSpec solved = kelvin::field_sigma(run.sigma, surface.vertices, welded.to_welded, welded.surface.vertices.rows());
  // "components" / "simplify" / "repair": the field is prepared on the reshaped surface, σ
  // carried to it (ReshapeRequest).
  Reshaped reshaped;
  if (run.reshape.any()) {
    reshaped = reshape_surface(surface, welded.surface, run.reshape, Limits{}, progress);
    solved = carry_sigma(std::move(solved), run.sigma, mesh::nearest_face_transfer(surface, reshaped.surface.vertices));
  }
  const mesh::SurfaceMesh& prepared = run.reshape.any() ? reshaped.surface : welded.surface;
  bool hit = false;
  kelvin::Field field = run.cached ? kelvin::Field::prepare_cached(prepared, run.options, run.store, progress, &hit)
                                   : kelvin::Field::prepare(prepared, run.options, progress);
  field.set_sigma(solved);

  json out;
  out["stats"] = stats_json(field, hit, run.cached);
  // Fallbacks taken while preparing (e.g. edge protection skipped on thin features).
  if (!field.stats().warnings.empty()) out["warnings"] = field.stats().warnings;
  out["mesh"] = {{"n_vertices", surface.vertices.rows()}, {"n_faces", surface.faces.rows()}, {"n_welded_vertices", welded.surface.vertices.rows()}};
  if (!reshaped.repair_report.is_null()) out["repair"] = reshaped.repair_report;
  if (!reshaped.simplify_report.is_null()) out["simplify"] = reshaped.simplify_report;
  if (!reshaped.components_report.is_null()) out["components"] = reshaped.components_report;
  out["query"] = query_json(field, run.points);
  if (!run.levels.empty()) out["isosurfaces"] = write_isosurfaces(field, run);
  return out;
}

}  // namespace distlab::server
