// distlab.gap: the CLI's request (solve) and batched distances over arrays of poses.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <list>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <unordered_map>
#include <vector>

#include <pybind11/numpy.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "distlab/gap/distance.hpp"
#include "distlab/gap/validator.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "interrupt.hpp"

namespace py = pybind11;
using json = nlohmann::json;

namespace distlab::python {
namespace {

using Poses = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Poses of an (N, 7) [x, y, z, qw, qx, qy, qz] or (N, 4, 4) array, checked as the JSON schema
// checks "pose" (finite, |position| <= kMaxCoordinate, quaternion normalised the same way).
std::vector<Pose> read_poses(const Poses& a, const std::string& field) {
  const bool matrices = a.ndim() == 3 && a.shape(1) == 4 && a.shape(2) == 4;
  if (!(matrices || (a.ndim() == 2 && a.shape(1) == 7)))
    throw InvalidInput(field, field + " must have shape (N, 7) (position, quaternion w x y z) or (N, 4, 4)");
  const auto n = static_cast<std::size_t>(a.shape(0));
  const double* d = a.data();
  std::vector<Pose> poses(n);
  for (std::size_t i = 0; i < n; ++i) {
    const auto f = [&] { return server::json_index_path(field, i); };  // built only for an error
    const double* p = d + i * (matrices ? 16 : 7);
    for (int k = 0; k < (matrices ? 16 : 7); ++k)
      if (!std::isfinite(p[k])) throw InvalidInput(f(), f() + " must be finite");
    Pose& pose = poses[i];
    if (!matrices) {
      pose.position = Vec3(p[0], p[1], p[2]);
      const double norm = Eigen::Vector4d(p[3], p[4], p[5], p[6]).stableNorm();
      if (!(norm >= server::kMinQuaternionNorm))
        throw InvalidInput(f(), "quaternion has (near) zero norm; it must be a rotation");
      pose.rotation = Quat(p[3] / norm, p[4] / norm, p[5] / norm, p[6] / norm);
    } else {
      const Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>> M(p);
      const Mat3 R = M.topLeftCorner<3, 3>();
      if ((R.transpose() * R - Mat3::Identity()).cwiseAbs().maxCoeff() > 1e-6 || R.determinant() <= 0 ||
          M.row(3) != Eigen::RowVector4d(0, 0, 0, 1))
        throw InvalidInput(f(), f() + " must be a rigid transform (orthonormal rotation, det +1, last row 0 0 0 1)");
      pose.position = M.topRightCorner<3, 1>();
      pose.rotation = Quat(R).normalized();
    }
    if (!(pose.position.cwiseAbs().maxCoeff() <= server::kMaxCoordinate))
      throw InvalidInput(f(), f() + " position must have magnitude <= " + json(server::kMaxCoordinate).dump());
  }
  return poses;
}

std::vector<Vec3> read_points(const py::object& o, std::size_t n, const std::string& field) {
  const auto a = Poses::ensure(o);
  if (!a || a.ndim() != 2 || a.shape(1) != 3 || static_cast<std::size_t>(a.shape(0)) != n)
    throw InvalidInput(field, field + " must have shape (" + std::to_string(n) + ", 3)");
  std::vector<Vec3> v(n);
  for (std::size_t i = 0; i < n; ++i) {
    v[i] = Vec3(a.at(i, 0), a.at(i, 1), a.at(i, 2));
    if (!v[i].allFinite()) throw InvalidInput(server::json_index_path(field, i), field + " must be finite");
  }
  return v;
}

// A shape dict of the JSON schema, parsed, built and (with validate) checked as the CLI does.
// Building costs far more than a pair (the base function's series, hulls, FCL geometry: 0.3 to
// 3 ms), so the last 256 bodies are kept by their JSON and parameters: a loop calling distance()
// with the same shapes builds them once. Only touched with the GIL held.
std::shared_ptr<const GapBody> build_body(const json& shape, const json& params, const server::GapRequestParams& rp,
                                          const std::string& field) {
  using Recent = std::list<std::pair<std::string, std::shared_ptr<const GapBody>>>;
  static Recent recent;  // most recent first
  static std::unordered_map<std::string, Recent::iterator> index;
  constexpr std::size_t kKept = 256;  // e.g. a robot's links and the obstacles around them
  std::string key = field + '\n' + shape.dump() + '\n' + params.dump();
  if (const auto it = index.find(key); it != index.end()) {
    recent.splice(recent.begin(), recent, it->second);
    return it->second->second;
  }
  const server::ShapeSpec spec = server::parse_shape(shape, field);
  auto body = std::make_shared<const GapBody>(spec.shape, Pose{}, rp.params, spec.options, field);
  if (rp.validate) {
    const ValidationReport report = validate_p2s(body->p2s());
    if (!report.ok) throw InvalidInput(field, report.message);
  }
  recent.emplace_front(key, body);
  index.emplace(std::move(key), recent.begin());
  if (recent.size() > kKept) {
    index.erase(recent.back().first);
    recent.pop_back();
  }
  return body;
}

// A pair's GapTrack as a row of doubles, so that a Result passed back as warm_start continues
// each pair from its last solution (gap_distance_tracked). The row starts with a tag of the
// shapes and parameters (a track from other bodies is ignored: its derivatives would mislead
// the prediction); the separating plane is not kept (the next call proves separation afresh).
constexpr std::size_t kTrackSize = 54;

void write_track(const GapTrack& t, std::uint64_t tag, double* o) {
  o[0] = static_cast<double>(tag >> 32), o[1] = static_cast<double>(tag & 0xffffffffu);
  o[2] = t.valid, o[3] = t.last.evaluated;
  double* x = o + 4;
  auto put = [&x](const auto& m) {
    for (Eigen::Index k = 0; k < m.size(); ++k) *x++ = m.data()[k];
  };
  put(t.pose_a.position), put(t.pose_a.rotation.coeffs()), put(t.pose_b.position), put(t.pose_b.rotation.coeffs());
  put(t.last.a), put(t.last.b), put(t.last.ab);
  *x++ = t.last.lambda;
  for (const P2SValue* e : {&t.last.ea, &t.last.eb}) *x++ = e->value, put(e->gradient), put(e->hessian);
}

// The track of a row written for the same tag, or an invalid one.
GapTrack read_track(const double* in, std::uint64_t tag) {
  GapTrack t;
  if (in[0] != static_cast<double>(tag >> 32) || in[1] != static_cast<double>(tag & 0xffffffffu) || in[2] != 1)
    return t;
  const double* x = in + 4;
  auto get = [&x](auto& m) {
    for (Eigen::Index k = 0; k < m.size(); ++k) m.data()[k] = *x++;
  };
  get(t.pose_a.position), get(t.pose_a.rotation.coeffs()), get(t.pose_b.position), get(t.pose_b.rotation.coeffs());
  get(t.last.a), get(t.last.b), get(t.last.ab);
  t.last.lambda = *x++;
  for (P2SValue* e : {&t.last.ea, &t.last.eb}) e->value = *x++, get(e->gradient), get(e->hessian);
  t.last.evaluated = in[3] == 1;
  t.last.converged = t.valid = true;
  return t;
}

py::dict gap_batch(const py::dict& shape_a, const Poses& poses_a, const py::dict& shape_b,
                   const Poses& poses_b, const py::object& params_dict, unsigned threads,
                   const py::object& warm_a, const py::object& warm_b, bool euclidean,
                   const py::object& progress, const py::object& track_in) {
  const json params_json = to_json(params_dict, "params");
  // Parsing checks h and k by building a base function (0.1 ms): the last parameters are kept.
  static std::optional<std::pair<json, server::GapRequestParams>> last_params;
  if (!last_params || last_params->first != params_json)
    last_params.emplace(params_json, server::parse_params(params_json));
  server::GapRequestParams rp = last_params->second;
  rp.params.euclidean = euclidean;  // off: an uncertified GJK start, no FCL (as distlab-bench-gap)
  const std::vector<Pose> pa = read_poses(poses_a, "pose_a"), pb = read_poses(poses_b, "pose_b");
  if (pa.size() != pb.size() && pa.size() != 1 && pb.size() != 1)
    throw InvalidInput("pose_b", "pose_a has " + std::to_string(pa.size()) + " poses and pose_b " +
                                     std::to_string(pb.size()) + " (give as many, or one of either)");
  const std::size_t n = pa.empty() || pb.empty() ? 0 : std::max(pa.size(), pb.size());
  const bool warm = !warm_a.is_none() || !warm_b.is_none();
  std::vector<Vec3> wa, wb;
  if (warm) {
    if (warm_a.is_none() || warm_b.is_none())
      throw InvalidInput("warm_start", "warm_start needs both witness arrays (witness_a, witness_b)");
    wa = read_points(warm_a, n, "warm_start.witness_a");
    wb = read_points(warm_b, n, "warm_start.witness_b");
  }
  std::optional<Poses> tracks;
  if (warm && !track_in.is_none()) {
    tracks = Poses::ensure(track_in);
    if (!*tracks || tracks->ndim() != 2 || static_cast<std::size_t>(tracks->shape(0)) != n ||
        static_cast<std::size_t>(tracks->shape(1)) != kTrackSize)
      throw InvalidInput("warm_start.track", "warm_start.track must have shape (" + std::to_string(n) + ", " +
                                                 std::to_string(kTrackSize) + ") (a Result's track)");
    for (py::ssize_t i = 0; i < tracks->size(); ++i)
      if (!std::isfinite(tracks->data()[i])) throw InvalidInput("warm_start.track", "warm_start.track must be finite");
  }
  const std::uint64_t tag = std::hash<std::string>{}(to_json(shape_a, "a").dump() + '\n' +
                                                     to_json(shape_b, "b").dump() + '\n' + params_json.dump() +
                                                     (euclidean ? "\ne" : "\n"));
  const auto proto_a = build_body(to_json(shape_a, "a"), params_json, rp, "a");
  const auto proto_b = build_body(to_json(shape_b, "b"), params_json, rp, "b");
  const GapParams& params = rp.params;

  const auto sn = static_cast<py::ssize_t>(n);
  py::array_t<double> lambda(sn), distance(sn), euclid(sn);
  py::array_t<double> wit_a({sn, py::ssize_t{3}}), wit_b({sn, py::ssize_t{3}});
  py::array_t<double> ewit_a({sn, py::ssize_t{3}}), ewit_b({sn, py::ssize_t{3}});
  py::array_t<double> grad_a({sn, py::ssize_t{6}}), grad_b({sn, py::ssize_t{6}});
  py::array_t<double> egrad_a({sn, py::ssize_t{6}}), egrad_b({sn, py::ssize_t{6}});
  py::array_t<std::int32_t> iterations(sn);
  py::array_t<bool> converged(sn), overlap(sn);
  py::array_t<double> track_out({warm ? sn : py::ssize_t{0}, static_cast<py::ssize_t>(kTrackSize)});
  double* const track_rows = track_out.mutable_data();
  const double* const track_rows_in = tracks ? tracks->data() : nullptr;
  struct Ptrs {
    double *lambda, *distance, *euclid, *wa, *wb, *ewa, *ewb, *ga, *gb, *ega, *egb;
    std::int32_t* iterations;
    bool *converged, *overlap;
  } o{lambda.mutable_data(), distance.mutable_data(), euclid.mutable_data(), wit_a.mutable_data(),
      wit_b.mutable_data(), ewit_a.mutable_data(), ewit_b.mutable_data(), grad_a.mutable_data(),
      grad_b.mutable_data(), egrad_a.mutable_data(), egrad_b.mutable_data(), iterations.mutable_data(),
      converged.mutable_data(), overlap.mutable_data()};

  std::atomic<std::size_t> first_bad{n}, done{0};
  Interruptible interrupt(progress);
  {
    py::gil_scoped_release release;
    // Blocks of pairs, each with its own copies of the two bodies (set_pose moves them). Between
    // blocks the calling thread (which takes a share) runs Ctrl-C's handler and, every 0.1 s,
    // progress(done, n); once cancelled the remaining blocks are skipped.
    constexpr std::size_t kBlock = 256;
    auto last_report = std::chrono::steady_clock::now();
    const auto caller = std::this_thread::get_id();
    parallel_for((n + kBlock - 1) / kBlock, threads, [&](std::size_t block) {
      if (!interrupt.poll()) return;
      if (!progress.is_none() && std::this_thread::get_id() == caller &&
          std::chrono::steady_clock::now() - last_report > std::chrono::milliseconds(100)) {
        last_report = std::chrono::steady_clock::now();
        if (!interrupt.report(done.load(), n)) return;
      }
      GapBody a = *proto_a, b = *proto_b;
      if (pa.size() == 1) a.set_pose(pa[0]);  // a shared pose is placed once (its world rows)
      if (pb.size() == 1) b.set_pose(pb[0]);
      const double nan = std::nan("");
      for (std::size_t i = block * kBlock; i < std::min(n, (block + 1) * kBlock); ++i) {
        if (pa.size() != 1) a.set_pose(pa[i]);
        if (pb.size() != 1) b.set_pose(pb[i]);
        GapResult r;
        if (warm) {
          // Each pair continues its own track; without one (or after an overlap), from the given
          // witnesses, as gap_distance_warm.
          GapTrack track = track_rows_in ? read_track(track_rows_in + kTrackSize * i, tag) : GapTrack{};
          if (!track.valid) track.last.a = wa[i], track.last.b = wb[i], track.valid = true;
          r = gap_distance_tracked(a, b, params, track);
          write_track(track, tag, track_rows + kTrackSize * i);
        } else {
          r = gap_distance(a, b, params);
        }
        o.lambda[i] = r.lambda;
        o.distance[i] = r.distance;
        o.iterations[i] = r.iterations;
        o.converged[i] = r.converged;
        o.overlap[i] = r.overlap;
        for (int k = 0; k < 3; ++k) {
          o.wa[3 * i + k] = r.witness_a[k];
          o.wb[3 * i + k] = r.witness_b[k];
          o.ewa[3 * i + k] = r.euclidean_computed ? r.euclidean.witness_a[k] : nan;
          o.ewb[3 * i + k] = r.euclidean_computed ? r.euclidean.witness_b[k] : nan;
        }
        for (int k = 0; k < 6; ++k) {
          o.ga[6 * i + k] = r.gradient_a[k];
          o.gb[6 * i + k] = r.gradient_b[k];
          o.ega[6 * i + k] = r.euclidean_computed ? r.euclidean.gradient_a[k] : nan;
          o.egb[6 * i + k] = r.euclidean_computed ? r.euclidean.gradient_b[k] : nan;
        }
        o.euclid[i] = r.euclidean_computed ? r.euclidean.distance : nan;
        const bool finite = std::isfinite(r.lambda) && r.witness_a.allFinite() && r.witness_b.allFinite() &&
                            r.gradient_a.allFinite() && r.gradient_b.allFinite();
        if (!finite)
          for (std::size_t f = first_bad.load(); i < f && !first_bad.compare_exchange_weak(f, i);) {
          }
      }
      done.fetch_add(std::min(n, (block + 1) * kBlock) - block * kBlock);
    });
  }
  if (interrupt.cancelled()) interrupt.raise();
  if (!progress.is_none() && !interrupt.report(n, n)) interrupt.raise();
  if (first_bad.load() < n)
    throw std::runtime_error("non-finite result for pair " + std::to_string(first_bad.load()) +
                             "; refusing to report it" +
                             (rp.validate ? "" : " (validate is off: parameters that break Property 2 can do this)"));
  py::dict out;
  out["lambda"] = lambda;
  out["distance"] = distance;
  out["witness_a"] = wit_a;
  out["witness_b"] = wit_b;
  out["iterations"] = iterations;
  out["converged"] = converged;
  out["overlap"] = overlap;
  out["gradient_a"] = params.gradient ? py::object(grad_a) : py::none();
  out["gradient_b"] = params.gradient ? py::object(grad_b) : py::none();
  out["euclidean_distance"] = euclid;
  out["euclidean_witness_a"] = ewit_a;
  out["euclidean_witness_b"] = ewit_b;
  out["euclidean_gradient_a"] = params.gradient ? py::object(egrad_a) : py::none();
  out["euclidean_gradient_b"] = params.gradient ? py::object(egrad_b) : py::none();
  out["track"] = warm ? py::object(track_out) : py::none();
  return out;
}

py::object gap_solve(const py::object& request) {
  const json j = to_json(request);
  json response;
  {
    py::gil_scoped_release release;
    response = server::run_gap_request(j);
  }
  return to_python(response);
}

py::dict default_params() {
  const GapParams p;
  py::dict d;
  d["h"] = p.h;
  d["k"] = p.k;
  d["eps"] = p.eps;
  d["sigma"] = p.sigma;
  d["weight_margin"] = p.weight_margin;
  d["tol"] = p.tol;
  d["max_iter"] = p.max_iter;
  d["solver"] = p.solver == GapSolver::newton ? "newton" : "fixed_point";
  d["gradient"] = p.gradient;
  d["validate"] = server::GapRequestParams{}.validate;
  return d;
}

}  // namespace

void bind_gap(py::module_& m) {
  m.def("gap_solve", &gap_solve, py::arg("request"));
  m.def("gap_batch", &gap_batch, py::arg("shape_a"), py::arg("poses_a"), py::arg("shape_b"), py::arg("poses_b"),
        py::arg("params"), py::arg("threads"), py::arg("warm_a"), py::arg("warm_b"),
        py::arg("euclidean") = true, py::arg("progress") = py::none(), py::arg("track") = py::none());
  m.def("gap_default_params", &default_params);
}

}  // namespace distlab::python
