// distlab.kelvin: the CLI's request (solve) and a prepared Field held in Python.
#include <cmath>
#include <functional>
#include <memory>
#include <string>

#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/stages.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "interrupt.hpp"

namespace py = pybind11;
using json = nlohmann::json;

namespace distlab::python {
namespace {

using Doubles = py::array_t<double, py::array::c_style | py::array::forcecast>;
using Ints = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;

// mesh_worker: the distlab executable that meshes mesh_threads > 1 in a child process
// (PrepareOptions::mesh_worker); "": in this process.
py::object kelvin_solve(const py::object& request, const py::object& progress, const std::string& mesh_worker) {
  const json j = to_json(request);
  Interruptible interrupt(progress);
  kelvin::Progress p;
  p.cancel = interrupt.flag();
  p.report = [&](const std::string& stage, double f) { interrupt.report(stage, f); };
  json response;
  interrupt.run([&] { response = server::run_kelvin_request(j, p, mesh_worker); });
  return to_python(response);
}

mesh::SurfaceMesh mesh_from_arrays(const py::object& vertices, const py::object& faces) {
  const auto V = Doubles::ensure(vertices);
  const auto F = Ints::ensure(faces);
  if (!V || V.ndim() != 2 || V.shape(1) != 3) throw InvalidInput("vertices", "vertices must have shape (n, 3)");
  if (!F || F.ndim() != 2 || F.shape(1) != 3) throw InvalidInput("faces", "faces must have shape (m, 3)");
  mesh::SurfaceMesh m;
  m.vertices.resize(V.shape(0), 3);
  m.faces.resize(F.shape(0), 3);
  for (py::ssize_t i = 0; i < V.shape(0); ++i)
    for (int k = 0; k < 3; ++k) {
      const double v = V.at(i, k);
      if (!(std::abs(v) <= server::kMaxCoordinate))
        throw InvalidInput(server::json_index_path("vertices", static_cast<std::size_t>(i)),
                           "vertices must be finite and within the coordinate limit");
      m.vertices(i, k) = v;
    }
  for (py::ssize_t i = 0; i < F.shape(0); ++i)
    for (int k = 0; k < 3; ++k) {
      const std::int64_t f = F.at(i, k);
      if (f < 0 || f >= V.shape(0))
        throw InvalidInput(server::json_index_path("faces", static_cast<std::size_t>(i)),
                           "face index " + std::to_string(f) + " is not a vertex (0 to " +
                               std::to_string(V.shape(0) - 1) + ")");
      m.faces(i, k) = static_cast<int>(f);
    }
  return m;
}

class PyField {
 public:
  // options: lx, center, far_radius, grading, feature_angle, max_vertices, mesh_threads (as the CLI
  // request's keys); mesh_worker as kelvin_solve's, for mesh_threads > 1 (as the CLI).
  static std::unique_ptr<PyField> prepare(const py::object& vertices, const py::object& faces, const py::object& path,
                                          const py::dict& options, const py::object& cache_dir,
                                          const py::object& progress, const std::string& mesh_worker) {
    const json o = to_json(options);
    kelvin::PrepareOptions po;
    po.lx = server::json_number(server::json_required(o, "", "lx"), "lx");
    if (auto c = server::json_optional(o, "center"); c && !c->is_null()) po.centre = server::json_vec3(*c, "center");
    if (auto v = server::json_optional(o, "far_radius"); v && !v->is_null())
      po.far_radius = server::json_positive(*v, "far_radius");
    if (auto v = server::json_optional(o, "grading"); v && !v->is_null()) po.grading = server::json_number(*v, "grading");
    if (auto v = server::json_optional(o, "feature_angle"); v && !v->is_null())
      po.feature_angle = server::json_number(*v, "feature_angle");
    if (auto v = server::json_optional(o, "max_vertices"); v && !v->is_null())
      po.max_vertices = static_cast<std::size_t>(server::json_integer(*v, "max_vertices", 100, 100000000));
    if (auto v = server::json_optional(o, "mesh_threads"); v && !v->is_null())
      po.mesh_threads = server::json_integer(*v, "mesh_threads", 0, kelvin::kMaxMeshThreads);
    server::use_mesh_worker(po, mesh_worker);
    // The file's unit (metres per unit, like the service's uploads) and the reshaping, read as
    // the CLI request reads them.
    double scale = 1.0;
    if (auto u = server::json_optional(o, "unit"); u && !u->is_null()) scale = server::unit_scale(server::json_string(*u, "unit"));
    if (auto v = server::json_optional(o, "scale"); v && !v->is_null()) {
      if (auto u = server::json_optional(o, "unit"); u && !u->is_null()) throw InvalidInput("scale", "give unit or scale, not both");
      scale = server::json_positive(*v, "scale");
    }
    json reshape_body = json::object();
    for (const char* k : {"components", "simplify", "repair", "repair_options"})
      if (auto v = server::json_optional(o, k); v && !v->is_null()) reshape_body[k] = *v;
    const server::ReshapeRequest reshape = server::parse_reshape(reshape_body, server::Limits{});
    mesh::SurfaceMesh surface;
    kelvin::FieldStore store;
    if (!cache_dir.is_none()) store.dir = py::str(cache_dir);
    if (auto v = server::json_optional(o, "cache_budget"); v && !v->is_null()) {
      if (store.dir.empty()) throw InvalidInput("cache_budget", "cache_budget needs cache_dir");
      store.budget_bytes = server::parse_cache_budget(*v, "cache_budget");
    }
    if (!path.is_none()) {
      const std::string p = py::str(path);
      py::gil_scoped_release release;
      surface = mesh::load_mesh(p, "path");
    } else {
      surface = mesh_from_arrays(vertices, faces);
    }
    if (scale != 1.0) {
      surface.vertices *= scale;
      if (!(surface.vertices.cwiseAbs().maxCoeff() <= server::kMaxCoordinate))
        throw InvalidInput("scale", "a coordinate times the scale is beyond the coordinate limit");
    }
    Interruptible interrupt(progress);
    kelvin::Progress pr;
    pr.cancel = interrupt.flag();
    pr.report = [&](const std::string& stage, double f) { interrupt.report(stage, f); };
    std::unique_ptr<PyField> field;
    interrupt.run([&] {
      bool hit = false;
      server::Reshaped reshaped;
      if (reshape.any()) reshaped = server::reshape_surface(surface, mesh::weld(surface).surface, reshape, server::Limits{}, pr);
      const mesh::SurfaceMesh& prepared = reshape.any() ? reshaped.surface : surface;
      field = std::make_unique<PyField>(store.dir.empty() ? kelvin::Field::prepare(prepared, po, pr)
                                                          : kelvin::Field::prepare_cached(prepared, po, store, pr, &hit));
      field->cache_hit_ = hit;
      field->reports_ = {{"repair", reshaped.repair_report}, {"simplify", reshaped.simplify_report}, {"components", reshaped.components_report}};
      field->field_.set_sigma(kelvin::SigmaSpec{});
    });
    return field;
  }

  explicit PyField(kelvin::Field f) : field_(std::move(f)) {}

  void set_sigma(const py::dict& sigma, bool gradients) {
    const kelvin::SigmaSpec spec = server::parse_sigma(to_json(sigma, "sigma"));
    py::gil_scoped_release release;
    field_.set_sigma(spec, gradients);
  }

  bool build_boundary_response(const py::object& max_mb, const py::object& progress) {
    const double max_megabytes = server::json_number(to_json(max_mb, "max_megabytes"), "max_megabytes");
    Interruptible interrupt(progress);
    kelvin::Progress pr;
    pr.cancel = interrupt.flag();
    pr.report = [&](const std::string& stage, double f) { interrupt.report(stage, f); };
    bool built = false;
    interrupt.run([&] { built = field_.build_boundary_response(max_megabytes, pr); });
    return built;
  }

  py::tuple query(const Doubles& points, bool hints) const {
    if (points.ndim() != 2 || points.shape(1) != 3) throw InvalidInput("points", "points must have shape (n, 3)");
    const py::ssize_t n = points.shape(0);
    const double* p = points.data();
    for (py::ssize_t i = 0; i < 3 * n; ++i)
      if (!std::isfinite(p[i]))
        throw InvalidInput(server::json_index_path("points", static_cast<std::size_t>(i / 3)), "points must be finite");
    py::array_t<double> h(n), grad({n, py::ssize_t{3}});
    py::array_t<std::int8_t> status(n);
    double* hp = h.mutable_data();
    double* gp = grad.mutable_data();
    std::int8_t* sp = status.mutable_data();
    {
      py::gil_scoped_release release;
      int hint = -1;
      for (py::ssize_t i = 0; i < n; ++i) {
        const kelvin::Sample s = field_.query(Vec3(p[3 * i], p[3 * i + 1], p[3 * i + 2]), hints ? &hint : nullptr);
        const bool ok = s.status == kelvin::Status::ok;
        hp[i] = ok ? s.h : std::nan("");
        for (int k = 0; k < 3; ++k) gp[3 * i + k] = ok ? s.gradient[k] : std::nan("");
        sp[i] = static_cast<std::int8_t>(s.status);
      }
    }
    return py::make_tuple(h, grad, status);
  }

  static py::tuple arrays(const mesh::SurfaceMesh& m) {
    py::array_t<double> V({static_cast<py::ssize_t>(m.vertices.rows()), py::ssize_t{3}});
    py::array_t<std::int32_t> F({static_cast<py::ssize_t>(m.faces.rows()), py::ssize_t{3}});
    std::copy(m.vertices.data(), m.vertices.data() + m.vertices.size(), V.mutable_data());
    std::copy(m.faces.data(), m.faces.data() + m.faces.size(), F.mutable_data());
    return py::make_tuple(V, F);
  }

  py::tuple isosurface(double level) const {
    server::json_number(json(level), "level");
    mesh::SurfaceMesh m;
    {
      py::gil_scoped_release release;
      m = field_.isosurface(level);
    }
    return arrays(m);
  }

  // Writes only a closed 2-manifold (else InvalidInput on level); returns its check.
  py::object export_mesh(const std::string& path, double level, const std::string& format) const {
    server::json_number(json(level), "level");
    json check;
    {
      py::gil_scoped_release release;
      const mesh::SurfaceMesh iso = field_.isosurface(level);
      const mesh::SurfaceReport report = mesh::inspect_surface(iso);
      if (iso.faces.rows() > 0 && !report.manifold())
        throw InvalidInput("level", "the iso-surface at h = " + json(level).dump() + " is not a closed 2-manifold (" +
                                        mesh::surface_defects(report) + "); not written");
      mesh::save_mesh(iso, path, format, "format");
      check = server::surface_check_json(report);
    }
    return to_python(check);
  }

  py::dict stats() const {
    const kelvin::Stats& s = field_.stats();
    py::dict d;
    d["n_verts"] = s.n_verts;
    d["n_tets"] = s.n_tets;
    d["size_mb"] = s.size_mb;
    d["t_mesh"] = s.t_mesh;
    d["t_build"] = s.t_build;
    d["t_decomp"] = s.t_decomp;
    d["t_solve"] = s.t_solve;
    d["grading"] = s.grading;
    d["mesh_threads"] = s.mesh_threads;
    d["response_mb"] = s.response_mb;
    d["linear_boundary"] = s.linear_boundary;
    d["linear_by_response"] = s.linear_by_response;
    d["cache_hit"] = cache_hit_;
    d["t_wait"] = s.t_wait;
    py::list warnings;
    for (const std::string& w : s.warnings) warnings.append(w);
    d["warnings"] = warnings;
    for (const auto& [k, v] : reports_.items())
      if (!v.is_null()) d[k.c_str()] = to_python(v);
    return d;
  }

  py::tuple surface() const { return arrays(field_.surface()); }
  py::array_t<double> centre() const {
    const Vec3 c = field_.centre();
    return py::array_t<double>(3, c.data());
  }

 private:
  kelvin::Field field_;
  bool cache_hit_ = false;
  json reports_ = json::object();  // components, simplify, repair: what reshaped the surface
};

// distlab.cache: the JSON of `distlab cache` (kelvin_json.hpp), as dicts.
py::object cache_call(const std::function<json()>& f) {
  json j;
  {
    py::gil_scoped_release release;
    j = f();
  }
  return to_python(j);
}

}  // namespace

void bind_kelvin(py::module_& m) {
  m.def("kelvin_solve", &kelvin_solve, py::arg("request"), py::arg("progress") = py::none(), py::arg("mesh_worker") = "");
  m.def("cache_default_dir", &server::default_cache_dir);
  m.def(
      "cache_ls", [](const std::string& dir) { return cache_call([&] { return server::cache_ls_json(dir); }); }, py::arg("dir"));
  m.def(
      "cache_verify", [](const std::string& dir, bool fix) { return cache_call([&] { return server::cache_verify_json(dir, fix); }); },
      py::arg("dir"), py::arg("fix"));
  m.def(
      "cache_gc",
      [](const std::string& dir, const py::object& budget, double keep_recent) {
        kelvin::FieldStore store{dir};
        if (!budget.is_none()) store.budget_bytes = server::parse_cache_budget(to_json(budget, "budget"), "budget");
        if (!(keep_recent >= 0 && keep_recent <= 1e9)) throw InvalidInput("keep_recent", "keep_recent must be in [0, 1e9] seconds");
        store.keep_recent_seconds = keep_recent;
        return cache_call([&] { return server::cache_gc_json(store); });
      },
      py::arg("dir"), py::arg("budget"), py::arg("keep_recent"));
  // A preparation's overall fraction from its (stage, fraction) reports, its stages weighed by
  // their typical seconds at `vertices` for the sizing `grading` (kelvin::StageProgress: the
  // server's, without its measured rates); `response`: a boundary response is built (the server
  // builds one, Field.prepare does not).
  py::class_<kelvin::StageProgress>(m, "KelvinStageProgress")
      .def(py::init([](double grading, double vertices, bool response) {
             kelvin::StageSeconds shares = kelvin::typical_stage_seconds(grading, vertices);
             if (!response) shares.back() = 0;
             return std::make_unique<kelvin::StageProgress>(shares);
           }),
           py::arg("grading") = kelvin::kAutoGrading, py::arg("vertices") = 1e4, py::arg("response") = false)
      .def("report", &kelvin::StageProgress::report, py::arg("stage"), py::arg("fraction"));
  py::class_<PyField>(m, "KelvinField")
      .def_static("prepare", &PyField::prepare, py::arg("vertices"), py::arg("faces"), py::arg("path"),
                  py::arg("options"), py::arg("cache_dir"), py::arg("progress"), py::arg("mesh_worker") = "")
      .def("set_sigma", &PyField::set_sigma, py::arg("sigma"), py::arg("gradients") = true)
      .def("build_boundary_response", &PyField::build_boundary_response, py::arg("max_megabytes"),
           py::arg("progress") = py::none())
      .def("query", &PyField::query, py::arg("points"), py::arg("hints") = true)
      .def("isosurface", &PyField::isosurface, py::arg("level"))
      .def("export", &PyField::export_mesh, py::arg("path"), py::arg("level"), py::arg("format"))
      .def("stats", &PyField::stats)
      .def("surface", &PyField::surface)
      .def("centre", &PyField::centre);
}

}  // namespace distlab::python
