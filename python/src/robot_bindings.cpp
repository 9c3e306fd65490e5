// distlab.robot: a URDF robot (backend/robot) from Python: forward kinematics, point Jacobians,
// every robot–obstacle and self distance with its gradient in joint space for a batch of
// configurations (robot::distances), and the CBF rows of a caller's own QP (cbf::cbf_rows).
#include <cmath>
#include <cstdint>
#include <list>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <pybind11/numpy.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "convert.hpp"
#include "distlab/cbf/controller.hpp"
#include "distlab/cbf/rows.hpp"
#include "distlab/cbf/scenario.hpp"
#include "distlab/robot/distances.hpp"
#include "distlab/robot/robot.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/robot_json.hpp"
#include "interrupt.hpp"

namespace py = pybind11;
using json = nlohmann::json;

namespace distlab::python {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using robot::GradQ;
using robot::Jac;
using robot::Kinematics;
using robot::VecQ;

constexpr std::size_t kModels = 8;  // DistanceModels kept per robot (obstacle sets, metrics, ...)
// From this many configurations a batch runs on a helper thread while the calling one watches
// for Ctrl-C (Interruptible::run: a thread start, ~50 µs); a shorter one (a controller's single
// configuration) runs on the calling thread without the GIL and is over in milliseconds.
constexpr int kInterruptibleFrom = 256;

// A numpy array owning `v` (moved, not copied).
template <class T>
py::array owning(std::vector<T>&& v, const std::vector<py::ssize_t>& shape, const py::dtype& dtype) {
  auto* held = new std::vector<T>(std::move(v));
  const py::capsule owner(held, [](void* p) { delete static_cast<std::vector<T>*>(p); });
  return py::array(dtype, shape, std::vector<py::ssize_t>{}, held->data(), owner);
}

std::string shape_text(const py::array& a) {
  std::string s = "(";
  for (py::ssize_t i = 0; i < a.ndim(); ++i) s += (i ? ", " : "") + std::to_string(a.shape(i));
  return s + (a.ndim() == 1 ? ",)" : ")");
}

// Configurations: (dof,) is one (its entries named "q[j]"), (N, dof) N of them ("q[i][j]").
struct Configs {
  const double* data = nullptr;
  int n = 0;
};

Configs read_q(const Array& q, const robot::Robot& robot) {
  const int dof = robot.dof();
  const bool single = q.ndim() == 1;
  if (!((single || q.ndim() == 2) && q.shape(q.ndim() - 1) == dof))
    throw InvalidInput("q", "q must have shape (" + std::to_string(dof) + ",) or (N, " + std::to_string(dof) +
                                ") (one entry per joint), got " + shape_text(q));
  if (!single && q.shape(0) > (py::ssize_t{1} << 30)) throw InvalidInput("q", "at most 2^30 configurations");
  const Configs c{q.data(), single ? 1 : static_cast<int>(q.shape(0))};
  for (int i = 0; i < c.n; ++i)
    robot.check_q(Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof),
                  single ? "q" : server::json_index_path("q", static_cast<std::size_t>(i)));
  return c;
}

// A DistanceModel and what it was built from (the cache key: the call's JSON, compared exactly,
// the obstacles' without their "pose": a moved obstacle keeps its model).
// The throw the check finds is nlohmann::json's unreachable internal-error branch of its noexcept
// default constructor (as for server::CbfSweep).
struct ModelEntry {  // NOLINT(bugprone-exception-escape)
  json obstacles, pairs, params;
  robot::Metric metric = robot::Metric::gap;
  std::shared_ptr<const robot::DistanceModel> model;
};

// A call's model and its obstacles' poses (in the model's obstacle order).
struct ModelCall {
  std::shared_ptr<const ModelEntry> entry;
  std::vector<Pose> obstacle_poses;
};

// The obstacles' JSON without each one's "pose" (the model's key); malformed JSON is left as it
// is, for parse_robot_obstacles to name its error.
json without_poses(json obstacles) {
  if (obstacles.is_array())
    for (json& o : obstacles)
      if (o.is_object()) o.erase("pose");
  return obstacles;
}

// The tracks a batch ended with: BatchOptions::warm_start of the next call with the same robot,
// obstacles, metric, pairs and params (any other is refused).
struct TrackState {
  std::shared_ptr<const ModelEntry> entry;
  std::vector<GapTrack> tracks;
};

// A robot and the DistanceModels its calls needed (most recent first), so a loop calling
// distances() for one configuration at a time builds its model once. Only touched with the GIL.
class PyRobot {
 public:
  // field: the argument the robot came from ("urdf", "name"), the field of a collision element's
  // Property 2 failure.
  PyRobot(std::shared_ptr<const robot::Robot> r, std::string field) : robot_(std::move(r)), field_(std::move(field)) {}
  const robot::Robot& robot() const { return *robot_; }
  const std::shared_ptr<const robot::Robot>& shared() const { return robot_; }

  ModelCall model(const py::object& obstacles, const std::string& metric, const py::object& pairs,
                  const py::object& params) {
    const robot::Metric m = server::parse_robot_metric(json(metric));
    const json oj = to_json(obstacles, "obstacles");
    json key = without_poses(oj), pj = to_json(pairs, "pairs"), prj = to_json(params, "params");
    for (auto it = models_.begin(); it != models_.end(); ++it) {
      const ModelEntry& e = **it;
      if (e.metric == m && e.params == prj && e.pairs == pj && e.obstacles == key) {
        models_.splice(models_.begin(), models_, it);
        // The same obstacles, checked when the model was built: only their poses are read.
        ModelCall call{models_.front(), {}};
        call.obstacle_poses.reserve(oj.size());
        for (std::size_t i = 0; i < oj.size(); ++i) {
          const json* pose = server::json_optional(oj[i], "pose");
          call.obstacle_poses.push_back(
              pose != nullptr ? server::json_pose(*pose, server::json_key_path(server::json_index_path("obstacles", i), "pose"))
                              : Pose{});
        }
        return call;
      }
    }
    const server::GapRequestParams rp = server::parse_params(prj, "params");
    if (!rp.params.gradient)
      throw InvalidInput("params.gradient", "robot distances always come with their Jacobians: leave gradient out or true");
    const robot::PairSelection selection = server::parse_pair_selection(pj);
    std::vector<robot::Obstacle> obs = server::parse_robot_obstacles(oj);
    std::vector<Pose> poses;
    poses.reserve(obs.size());
    for (const robot::Obstacle& o : obs) poses.push_back(o.pose);
    auto entry = std::make_shared<ModelEntry>();
    entry->metric = m;
    {
      py::gil_scoped_release release;  // GAP bodies, FCL geometry and the validation: milliseconds
      entry->model = std::make_shared<const robot::DistanceModel>(robot_, std::move(obs), m, rp.params, selection);
      if (rp.validate) server::validate_robot_bodies(*entry->model, field_);
    }
    // Elements that took their own h (robot::element_params): once per model, as UserWarnings.
    for (const std::string& w : entry->model->warnings())
      if (PyErr_WarnEx(PyExc_UserWarning, w.c_str(), 1) != 0) throw py::error_already_set();
    entry->obstacles = std::move(key);
    entry->pairs = std::move(pj);
    entry->params = std::move(prj);
    models_.push_front(entry);
    if (models_.size() > kModels) models_.pop_back();
    return {std::move(entry), std::move(poses)};
  }

 private:
  std::shared_ptr<const robot::Robot> robot_;
  std::string field_;
  std::list<std::shared_ptr<const ModelEntry>> models_;
};

// The state passed as warm_start, checked against the model of this call.
std::shared_ptr<TrackState> read_warm_start(const py::object& warm, const ModelEntry& entry, bool tracking) {
  if (warm.is_none()) return nullptr;
  if (!py::isinstance<TrackState>(warm))
    throw InvalidInput("warm_start", "warm_start must be a previous result (or its .state) or None, got a " +
                                         std::string(py::str(py::type::of(warm).attr("__name__"))));
  if (!tracking) throw InvalidInput("warm_start", "warm_start needs tracking=True (without it every configuration is solved cold)");
  auto state = warm.cast<std::shared_ptr<TrackState>>();
  if (state->entry == nullptr) throw InvalidInput("warm_start", "warm_start is empty");
  if (state->entry.get() == &entry) return state;
  const ModelEntry& from = *state->entry;
  if (from.model->robot_ptr() != entry.model->robot_ptr())
    throw InvalidInput("warm_start", "warm_start comes from another robot");
  if (from.metric != entry.metric)
    throw InvalidInput("warm_start", std::string("warm_start comes from the metric \"") + robot::to_string(from.metric) +
                                         "\", not \"" + robot::to_string(entry.metric) + "\"");
  if (from.obstacles != entry.obstacles || from.pairs != entry.pairs || from.params != entry.params)
    throw InvalidInput("warm_start", "warm_start comes from another obstacle set, pair selection or params");
  return state;
}

robot::DistanceBatch run_batch(const ModelCall& call, const Configs& q, unsigned threads, const TrackState* warm,
                               bool tracking) {
  const ModelEntry& entry = *call.entry;
  robot::BatchOptions o;
  o.threads = threads;
  o.tracking = tracking;
  o.obstacle_poses = call.obstacle_poses;
  if (warm != nullptr) o.warm_start = warm->tracks;
  const std::span<const double> qs(q.data, static_cast<std::size_t>(q.n) * entry.model->dof());
  robot::DistanceBatch b;
  if (q.n < kInterruptibleFrom) {
    py::gil_scoped_release release;
    b = robot::distances(*entry.model, qs, q.n, o);
  } else {
    Interruptible interrupt{py::none()};
    o.cancel = interrupt.flag();
    interrupt.run([&] { b = robot::distances(*entry.model, qs, q.n, o); });
  }
  return b;
}

// (distance, jacobian, witness_robot, witness_obstacle, overlap, converged, iterations, state,
// obstacle_gradient), arrays with the leading N axis.
py::tuple batch_tuple(robot::DistanceBatch&& b, std::shared_ptr<const ModelEntry> entry) {
  const py::ssize_t n = b.n, p = b.pairs, dof = b.dof;
  auto state = std::make_shared<TrackState>();
  state->entry = std::move(entry);
  state->tracks = std::move(b.tracks);
  const py::dtype f64 = py::dtype::of<double>(), boolean("bool");
  return py::make_tuple(owning(std::move(b.distance), {n, p}, f64), owning(std::move(b.jacobian), {n, p, dof}, f64),
                        owning(std::move(b.witness_robot), {n, p, 3}, f64),
                        owning(std::move(b.witness_obstacle), {n, p, 3}, f64),
                        owning(std::move(b.overlap), {n, p}, boolean), owning(std::move(b.converged), {n, p}, boolean),
                        owning(std::move(b.iterations), {n, p}, py::dtype::of<int>()),
                        std::shared_ptr<TrackState>(std::move(state)),
                        owning(std::move(b.obstacle_gradient), {n, p, 6}, f64));
}

py::tuple robot_distances(PyRobot& self, const Array& q, const py::object& obstacles, const std::string& metric,
                          const py::object& pairs, const py::object& params, unsigned threads, const py::object& warm_start,
                          bool tracking) {
  const Configs c = read_q(q, self.robot());
  ModelCall call = self.model(obstacles, metric, pairs, params);
  const auto warm = read_warm_start(warm_start, *call.entry, tracking);
  robot::DistanceBatch b = run_batch(call, c, threads, warm.get(), tracking);
  return batch_tuple(std::move(b), std::move(call.entry));
}

// Kelvin fields as barriers of a robot's control points (cbf/fields.hpp): the scenario's "fields"
// and "control_points", prepared once (through the disk cache), evaluated for any q.
class PyFieldBarrier {
 public:
  PyFieldBarrier(const PyRobot& r, const py::object& fields, const py::object& control_points, const py::object& cache_dir)
      : robot_(r.shared()) {
    cbf::Scenario s;
    s.robot = robot_;
    const json j = {{"fields", to_json(fields, "fields")}, {"control_points", to_json(control_points, "control_points")}};
    if (!j["fields"].is_array() || j["fields"].empty()) throw InvalidInput("fields", "fields needs at least one Kelvin object");
    if (!j["control_points"].is_array() || j["control_points"].empty())
      throw InvalidInput("control_points", "control_points needs at least one entry");
    const std::string cache = cache_dir.is_none() ? server::default_cache_dir() : std::string(py::str(cache_dir));
    const server::FieldPreparer prepare = [cache](const mesh::SurfaceMesh& m, const kelvin::PrepareOptions& o, const std::string&) {
      return cache.empty() ? kelvin::Field::prepare(m, o) : kelvin::Field::prepare_cached(m, o, cache);
    };
    {
      py::gil_scoped_release release;
      server::parse_scenario_fields(j, "", "", prepare, s);
    }
    barrier_ = std::make_unique<cbf::FieldBarrier>(std::move(s.fields), std::move(s.control_points));
    for (const cbf::SceneField& f : barrier_->fields())
      for (const cbf::ControlPoint& c : barrier_->points()) {
        names_.push_back(c.name + "/" + f.name);
        margins_.push_back(f.margin);
      }
  }
  const robot::Robot& robot() const { return *robot_; }
  cbf::FieldBarrier& barrier() { return *barrier_; }
  const std::vector<double>& margins() const { return margins_; }
  const std::vector<std::string>& names() const { return names_; }
  py::list points() const {
    py::list out;
    for (const cbf::ControlPoint& c : barrier_->points())
      out.append(py::dict(py::arg("name") = c.name, py::arg("link") = robot_->links()[static_cast<std::size_t>(c.link)],
                          py::arg("point") = py::make_tuple(c.point.x(), c.point.y(), c.point.z())));
    return out;
  }

  // h (N, R), ∇_q h (N, R, dof) and status (N, R) (0 ok, 1 inside, 2 V ≤ 0: h and ∇h NaN) for q
  // (N, dof), in turn (each row's cell search starts at its previous cell).
  py::tuple evaluate(const Array& q, const std::string& gradient) {
    if (gradient != "smoothed" && gradient != "cell") throw InvalidInput("gradient", "gradient is \"smoothed\" or \"cell\"");
    const Configs c = read_q(q, *robot_);
    const int rows = barrier_->rows(), dof = robot_->dof();
    std::vector<double> h(static_cast<std::size_t>(c.n) * rows), g(static_cast<std::size_t>(c.n) * rows * dof);
    std::vector<std::int32_t> status(static_cast<std::size_t>(c.n) * rows);
    {
      py::gil_scoped_release release;
      std::vector<cbf::FieldPointSample> s;
      Eigen::MatrixXd grad;
      robot::Kinematics k;
      for (int i = 0; i < c.n; ++i) {
        robot_->forward(Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof), k);
        barrier_->evaluate(*robot_, k, s, grad, gradient == "cell" ? kelvin::Gradient::cell : kelvin::Gradient::smoothed);
        for (int r = 0; r < rows; ++r) {
          const std::size_t cell = static_cast<std::size_t>(i) * rows + r;
          h[cell] = s[static_cast<std::size_t>(r)].h;
          status[cell] = static_cast<std::int32_t>(s[static_cast<std::size_t>(r)].status);
          for (int j = 0; j < dof; ++j)
            g[cell * dof + j] = s[static_cast<std::size_t>(r)].status == kelvin::Status::ok ? grad(r, j) : std::nan("");
        }
      }
    }
    const py::ssize_t n = c.n;
    return py::make_tuple(owning(std::move(h), {n, rows}, py::dtype::of<double>()),
                          owning(std::move(g), {n, rows, dof}, py::dtype::of<double>()),
                          owning(std::move(status), {n, rows}, py::dtype::of<std::int32_t>()));
  }

 private:
  std::shared_ptr<const robot::Robot> robot_;
  std::unique_ptr<cbf::FieldBarrier> barrier_;
  std::vector<std::string> names_;
  std::vector<double> margins_;
};

// margins: None (the scenario defaults of the metric) or {"obstacle", "self"} (either may be left out).
cbf::Margins parse_margins(const json& j, robot::Metric metric) {
  cbf::Margins m = cbf::Scenario{}.margins(metric);
  if (j.is_null()) return m;
  server::json_require_object(j, "margins");
  server::json_check_keys(j, "margins", {"obstacle", "self"});
  for (auto [key, value] : {std::pair{"obstacle", &m.obstacle}, std::pair{"self", &m.self}})
    if (const json* v = server::json_optional(j, key)) {
      const std::string f = server::json_key_path("margins", key);
      *value = server::json_number(*v, f, server::kMaxCoordinate);
      if (*value < 0) throw InvalidInput(f, f + " must be >= 0");
    }
  return m;
}

double positive(double v, const char* field) {
  if (!(std::isfinite(v) && v > 0)) throw InvalidInput(field, std::string(field) + " must be finite and > 0");
  return v;
}

// The rows A u >= b of every configuration (cbf::cbf_rows on the batch's distances and
// Jacobians): (A (N, R, dof), b (N, R), the distances' tuple).
py::tuple robot_cbf_rows(PyRobot& self, const Array& q, const py::object& obstacles, const std::string& metric,
                         const py::object& pairs, const py::object& margins, double eta, double eta_joint,
                         const py::object& params, unsigned threads, const py::object& warm_start, bool tracking,
                         PyFieldBarrier* fields) {
  if (fields && fields->robot().name() != self.robot().name())
    throw InvalidInput("fields", "the field barrier belongs to robot \"" + fields->robot().name() + "\"");
  const robot::Robot& robot = self.robot();
  const Configs c = read_q(q, robot);
  const ModelCall call = self.model(obstacles, metric, pairs, params);
  const std::shared_ptr<const ModelEntry>& entry = call.entry;
  const cbf::RowParams rp{parse_margins(to_json(margins, "margins"), entry->metric), positive(eta, "eta"),
                          positive(eta_joint, "eta_joint")};
  const auto warm = read_warm_start(warm_start, *entry, tracking);
  robot::DistanceBatch b = run_batch(call, c, threads, warm.get(), tracking);
  const int np = b.pairs, dof = b.dof;
  const int nf = fields ? fields->barrier().rows() : 0;
  const int rows = np + nf + cbf::joint_limit_rows(robot);
  std::vector<double> A(static_cast<std::size_t>(c.n) * rows * dof), d(static_cast<std::size_t>(c.n) * rows);
  {
    py::gil_scoped_release release;
    const auto& table = entry->model->pairs();
    std::vector<robot::PairDistance> distances(static_cast<std::size_t>(np));
    GradQ grad(np, dof);
    Eigen::MatrixXd C, field_grad;
    Eigen::VectorXd dv;
    std::vector<cbf::FieldPointSample> field_samples;
    robot::Kinematics k;
    using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;
    for (int i = 0; i < c.n; ++i) {
      const std::size_t cell = static_cast<std::size_t>(i) * np;
      for (int p = 0; p < np; ++p) distances[p].distance = b.distance[cell + p];
      grad = Eigen::Map<const RowMajor>(b.jacobian.data() + cell * dof, np, dof);
      const VecQ qi = Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof);
      cbf::FieldRows field_rows;
      if (fields) {
        robot.forward(qi, k);
        fields->barrier().evaluate(robot, k, field_samples, field_grad);
        cbf::require_defined(field_samples, fields->barrier().fields(), fields->barrier().points());
        field_rows = {field_samples, &field_grad, fields->margins()};
      }
      cbf::cbf_rows(robot, table, qi, distances, grad, rp, C, dv, field_rows);
      Eigen::Map<RowMajor>(A.data() + static_cast<std::size_t>(i) * rows * dof, rows, dof) = C;
      Eigen::Map<Eigen::VectorXd>(d.data() + static_cast<std::size_t>(i) * rows, rows) = dv;
    }
  }
  const py::ssize_t n = c.n;
  const py::dtype f64 = py::dtype::of<double>();
  py::array a_arr = owning(std::move(A), {n, rows, dof}, f64), b_arr = owning(std::move(d), {n, rows}, f64);
  return py::make_tuple(a_arr, b_arr, batch_tuple(std::move(b), entry));
}

// The pair table of a state's model, in the order of its arrays' P axis.
py::list pair_table(const TrackState& s) {
  const robot::DistanceModel& m = *s.entry->model;
  const auto& prims = m.robot().primitives();
  const auto& links = m.robot().links();
  py::list out;
  for (const robot::RobotPair& p : m.pairs()) {
    const robot::LinkPrimitive& a = prims[p.a];
    py::dict d;
    d["name"] = p.name;
    d["self"] = p.self;
    d["link"] = links[a.link];
    d["element"] = a.element;
    d["element_name"] = a.name;
    d["obstacle"] = p.self ? py::object(py::none()) : py::object(py::int_(p.b));
    d["obstacle_name"] = p.self ? py::object(py::none()) : py::object(py::str(m.obstacles()[p.b].name));
    if (p.self) {
      const robot::LinkPrimitive& b = prims[p.b];
      d["other_link"] = links[b.link];
      d["other_element"] = b.element;
      d["other_element_name"] = b.name;
    } else {
      d["other_link"] = py::none();
      d["other_element"] = py::none();
      d["other_element_name"] = py::none();
    }
    out.append(d);
  }
  return out;
}

// (N, L, 7): every link's world pose [x, y, z, qw, qx, qy, qz], links in Robot::links() order.
py::array robot_fk(const PyRobot& self, const Array& q) {
  const robot::Robot& robot = self.robot();
  const Configs c = read_q(q, robot);
  const auto nl = static_cast<int>(robot.links().size());
  const int dof = robot.dof();
  std::vector<double> out(static_cast<std::size_t>(c.n) * nl * 7);
  {
    py::gil_scoped_release release;
    Kinematics k;
    for (int i = 0; i < c.n; ++i) {
      robot.forward(Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof), k);
      for (int l = 0; l < nl; ++l) {
        double* o = out.data() + (static_cast<std::size_t>(i) * nl + l) * 7;
        const Pose& f = k.frames[l];
        o[0] = f.position.x(), o[1] = f.position.y(), o[2] = f.position.z();
        o[3] = f.rotation.w(), o[4] = f.rotation.x(), o[5] = f.rotation.y(), o[6] = f.rotation.z();
      }
    }
  }
  return owning(std::move(out), {c.n, nl, 7}, py::dtype::of<double>());
}

int link_of(const robot::Robot& robot, const py::object& link) {
  if (link.is_none()) return robot.ee_link();
  if (!py::isinstance<py::str>(link)) throw InvalidInput("link", "link must be a link name (str) or None");
  const auto name = link.cast<std::string>();
  const int l = robot.link_index(name);
  if (l < 0) throw InvalidInput("link", "\"" + name.substr(0, 64) + "\" is not a link of the robot");
  return l;
}

// (N, 6, dof): the geometric Jacobian [linear velocity; angular velocity] (world frame) of the
// point `point` (link frame) fixed to `link` (default the end effector, point its origin).
py::array robot_jacobian(const PyRobot& self, const Array& q, const py::object& link, const py::object& point) {
  const robot::Robot& robot = self.robot();
  const Configs c = read_q(q, robot);
  const int l = link_of(robot, link);
  Vec3 local = Vec3::Zero();
  if (!point.is_none()) {
    const json j = to_json(point, "point");
    local = server::json_vec3(j, "point", server::kMaxCoordinate);
  }
  const int dof = robot.dof();
  std::vector<double> out(static_cast<std::size_t>(c.n) * 6 * dof);
  {
    py::gil_scoped_release release;
    Kinematics k;
    Jac J;
    for (int i = 0; i < c.n; ++i) {
      robot.forward(Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof), k);
      robot.point_jacobian(k, l, k.frames[l].to_world(local), J);
      Eigen::Map<Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::RowMajor>>(out.data() + static_cast<std::size_t>(i) * 6 * dof, 6, dof) = J;
    }
  }
  return owning(std::move(out), {c.n, 6, dof}, py::dtype::of<double>());
}

std::shared_ptr<PyRobot> robot_from_file(const std::string& path, const std::map<std::string, std::string>& package_dirs,
                                         const std::vector<std::string>& package_search_dirs, bool require_closed_meshes) {
  robot::UrdfOptions options;
  options.package_dirs = package_dirs;
  options.package_search_dirs = package_search_dirs;
  options.require_closed_meshes = require_closed_meshes;
  std::shared_ptr<const robot::Robot> r;
  {
    py::gil_scoped_release release;  // meshes are read and their hulls computed
    r = robot::Robot::from_file(path, "urdf", options);
  }
  return std::make_shared<PyRobot>(std::move(r), "urdf");
}

std::shared_ptr<PyRobot> robot_load(const std::string& name) {
  std::shared_ptr<const robot::Robot> r;
  {
    py::gil_scoped_release release;
    r = server::load_robot(name, "", "name");
  }
  return std::make_shared<PyRobot>(std::move(r), "name");
}

py::array vec_array(const VecQ& v) {
  py::array_t<double> a(v.size());
  for (Eigen::Index i = 0; i < v.size(); ++i) a.mutable_at(i) = v[i];
  return a;
}

const char* shape_type(const Shape& s) {
  if (std::holds_alternative<Box>(s)) return "box";
  if (std::holds_alternative<Sphere>(s)) return "sphere";
  if (std::holds_alternative<Cylinder>(s)) return "cylinder";
  if (std::holds_alternative<Capsule>(s)) return "capsule";
  return "convex_hull";
}

py::list collision_elements(const PyRobot& self) {
  const robot::Robot& robot = self.robot();
  py::list out;
  for (const robot::LinkPrimitive& p : robot.primitives()) {
    py::dict d;
    d["name"] = p.name;
    d["link"] = robot.links()[p.link];
    d["element"] = p.element;
    d["type"] = shape_type(p.shape);
    d["mesh"] = p.mesh.empty() ? py::object(py::none()) : py::object(py::str(p.mesh));
    py::array_t<double> pose(7);
    const double v[7] = {p.pose.position.x(), p.pose.position.y(), p.pose.position.z(), p.pose.rotation.w(),
                         p.pose.rotation.x(), p.pose.rotation.y(), p.pose.rotation.z()};
    std::copy(v, v + 7, pose.mutable_data());
    d["pose"] = pose;
    out.append(d);
  }
  return out;
}

// The built-in controller's rows C u >= d at each configuration of q in turn (CbfController::rows,
// its tracks continued from one to the next), for the request {"scenario", "metric", "params"}
// of distlab.cbf: what Robot.cbf_rows is compared with.
py::tuple cbf_controller_rows(const py::object& request, const Array& q) {
  const server::CbfRequest r = server::parse_cbf_request(to_json(request));
  cbf::CbfController controller(r.scenario, r.metric);
  const Configs c = read_q(q, controller.robot());
  const int dof = controller.robot().dof();
  const int rows = static_cast<int>(controller.pairs().size()) + controller.field_rows() + cbf::joint_limit_rows(controller.robot());
  std::vector<double> A(static_cast<std::size_t>(c.n) * rows * dof), d(static_cast<std::size_t>(c.n) * rows);
  {
    py::gil_scoped_release release;
    Eigen::MatrixXd C;
    Eigen::VectorXd dv;
    for (int i = 0; i < c.n; ++i) {
      controller.rows(Eigen::Map<const VecQ>(c.data + static_cast<std::size_t>(i) * dof, dof), C, dv);
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(
          A.data() + static_cast<std::size_t>(i) * rows * dof, rows, dof) = C;
      Eigen::Map<Eigen::VectorXd>(d.data() + static_cast<std::size_t>(i) * rows, rows) = dv;
    }
  }
  const py::ssize_t n = c.n;
  py::list names;
  for (const robot::RobotPair& p : controller.pairs()) names.append(p.name);
  return py::make_tuple(owning(std::move(A), {n, rows, dof}, py::dtype::of<double>()),
                        owning(std::move(d), {n, rows}, py::dtype::of<double>()), names);
}

}  // namespace

void bind_robot(py::module_& m) {
  py::class_<TrackState, std::shared_ptr<TrackState>>(m, "RobotState")
      .def("pairs", &pair_table)
      .def_property_readonly("metric", [](const TrackState& s) { return robot::to_string(s.entry->metric); })
      .def("__repr__", [](const TrackState& s) {
        return "<distlab.robot state: " + std::to_string(s.tracks.size()) + " pairs, metric " +
               robot::to_string(s.entry->metric) + ">";
      });
  py::class_<PyRobot, std::shared_ptr<PyRobot>>(m, "Robot")
      .def_static("from_file", &robot_from_file, py::arg("path"), py::arg("package_dirs"),
                  py::arg("package_search_dirs"), py::arg("require_closed_meshes"))
      .def_static("load", &robot_load, py::arg("name"))
      .def_property_readonly("name", [](const PyRobot& r) { return r.robot().name(); })
      .def_property_readonly("dof", [](const PyRobot& r) { return r.robot().dof(); })
      .def_property_readonly("joint_names", [](const PyRobot& r) { return r.robot().joint_names(); })
      .def_property_readonly("joint_types", [](const PyRobot& r) {
        std::vector<std::string> t;
        for (robot::JointType j : r.robot().joint_types()) t.emplace_back(j == robot::JointType::prismatic ? "prismatic" : "revolute");
        return t;
      })
      .def_property_readonly("links", [](const PyRobot& r) { return r.robot().links(); })
      .def_property_readonly("ee_link", [](const PyRobot& r) { return r.robot().links()[r.robot().ee_link()]; })
      .def_property_readonly("q_min", [](const PyRobot& r) { return vec_array(r.robot().q_min()); })
      .def_property_readonly("q_max", [](const PyRobot& r) { return vec_array(r.robot().q_max()); })
      .def_property_readonly("velocity_max", [](const PyRobot& r) { return vec_array(r.robot().velocity_max()); })
      .def_property_readonly("collision_elements", &collision_elements)
      .def_property_readonly("warnings", [](const PyRobot& r) { return r.robot().warnings(); })
      .def("fk", &robot_fk, py::arg("q"))
      .def("jacobian", &robot_jacobian, py::arg("q"), py::arg("link") = py::none(), py::arg("point") = py::none())
      .def("distances", &robot_distances, py::arg("q"), py::arg("obstacles"), py::arg("metric"), py::arg("pairs"), py::arg("params"), py::arg("threads"), py::arg("warm_start"), py::arg("tracking"))
      .def("cbf_rows", &robot_cbf_rows, py::arg("q"), py::arg("obstacles"), py::arg("metric"), py::arg("pairs"), py::arg("margins"), py::arg("eta"), py::arg("eta_joint"), py::arg("params"), py::arg("threads"), py::arg("warm_start"), py::arg("tracking"), py::arg("fields"));
  py::class_<PyFieldBarrier>(m, "FieldBarrier")
      .def(py::init<const PyRobot&, const py::object&, const py::object&, const py::object&>(), py::arg("robot"),
           py::arg("fields"), py::arg("control_points"), py::arg("cache_dir"))
      .def("evaluate", &PyFieldBarrier::evaluate, py::arg("q"), py::arg("gradient"))
      .def_property_readonly("names", &PyFieldBarrier::names)
      .def_property_readonly("margins", [](const PyFieldBarrier& b) { return b.margins(); })
      .def_property_readonly("points", &PyFieldBarrier::points);
  m.def("cbf_controller_rows", &cbf_controller_rows, py::arg("request"), py::arg("q"));
}

}  // namespace distlab::python
