// A decoded robot distances request run (robot_run.hpp): the robot resolved, q checked against its
// dof, the configurations in chunks.
#include "robot_run.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <span>
#include <utility>

#include "distlab/geometry/error.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/json_text.hpp"
#include "distlab/server/request_params.hpp"

namespace distlab::server {
namespace {

using json = nlohmann::json;
namespace fs = std::filesystem;

// Work between two checks of the time limit: 4096 pairs of a Newton solve at its iteration limit
// (100); a fixed-point solve may take 1000 times more per pair, so its chunks hold that many fewer
// pairs. At least one configuration: the library checks nothing within one.
constexpr double kChunkIterations = 4096.0 * 100;

[[noreturn]] void fail(const std::string& field, const std::string& message) { throw InvalidInput(field, message); }

// (Appended, not "\"" + ... + "\"": GCC 12's false -Wrestrict, bug 105329, when inlined here.)
std::string in_quotes(const std::string& s) {
  std::string out = "\"";
  out += shorten(s);
  out += '"';
  return out;
}

bool name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
}

}  // namespace

std::vector<std::string> builtin_robot_names(const std::string& robots_dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(robots_dir, ec))
    if (e.path().extension() == ".urdf" && valid_name(e.path().stem().string())) names.push_back(e.path().stem().string());
  std::sort(names.begin(), names.end());
  return names;
}

std::shared_ptr<const robot::Robot> builtin_robot(const std::string& name, const std::string& robots_dir,
                                                  const std::string& field) {
  const std::vector<std::string> names = builtin_robot_names(robots_dir);
  if (std::find(names.begin(), names.end(), name) == names.end()) {
    std::string known;
    for (const std::string& k : names) known += (known.empty() ? "" : ", ") + k;
    fail(field, "unknown robot " + in_quotes(name) + " (built-in: " + known + "; or give {\"urdf\": TEXT})");
  }
  try {
    return robot::Robot::load((fs::path(robots_dir) / (name + ".urdf")).string(), field);
  } catch (const InvalidInput& e) {  // a broken asset is the server's fault, not the caller's
    throw std::runtime_error("robot file " + name + ".urdf: " + e.what());
  }
}

std::shared_ptr<const robot::Robot> urdf_robot(const RobotUrdf& urdf, const std::map<std::string, std::shared_ptr<const Upload>>& meshes) {
  const std::string uf = "robot.urdf", mf = "robot.meshes";
  const std::string& xml = urdf.text;
  // The URDF's filenames are keys of `meshes`: a relative one needs some folder and a package://
  // one its package for resolve_mesh_path to pass it on; nothing is read from either.
  robot::UrdfOptions options;
  options.limits = urdf.limits;
  options.base_dir = "/upload";
  for (std::size_t at = xml.find("package://"); at != std::string::npos; at = xml.find("package://", at + 1)) {
    const std::size_t begin = at + 10;
    std::size_t end = begin;
    while (end < xml.size() && name_char(xml[end])) ++end;
    options.package_dirs.emplace(xml.substr(begin, end - begin), "/upload");
  }
  std::set<std::string> read;
  std::string reading;  // the filename whose hull is being made (its defects name its entry)
  options.read_mesh = [&](const std::string& filename, const std::string&, const std::string&) {
    const auto it = meshes.find(filename);
    if (it == meshes.end())
      fail(mf, "the URDF's mesh " + in_quotes(filename) + " has no upload: add " + json(shorten(filename)).dump() +
                   ": UPLOAD_ID to robot.meshes (POST /api/kelvin/uploads)");
    read.insert(filename);
    reading = filename;
    return it->second->surface;
  };
  std::shared_ptr<const robot::Robot> robot;
  try {
    robot = robot::Robot::from_urdf(xml, uf, options);
  } catch (const InvalidInput& e) {
    // The library names the URDF element in the message. A defect of the mesh just read (flat,
    // too many facets: the message names it) is its upload's; the rest is the URDF's.
    if (e.field() == mf) throw;
    const std::string what = e.what();
    if (!reading.empty() && what.find("mesh \"" + reading.substr(0, 200) + "\"") != std::string::npos)
      throw InvalidInput(robot_mesh_field(reading), what);
    throw InvalidInput(uf, what);
  }
  for (const auto& [filename, upload] : meshes)
    if (!read.count(filename))
      fail(robot_mesh_field(filename), "the URDF has no <mesh filename=" + in_quotes(filename) + ">");
  return robot;
}

std::vector<double> robot_configurations(const RobotQ& q, int dof) {
  const std::string numbers = std::to_string(dof) + " numbers";
  if (q.rows.empty()) fail("q", "q must be one configuration [" + numbers + "] or several [[...], ...]");
  std::vector<double> out;
  out.reserve(q.rows.size() * static_cast<std::size_t>(dof));
  for (std::size_t i = 0; i < q.rows.size(); ++i) {
    const RobotQRow& row = q.rows[i];
    const std::string f = q.several ? json_index_path("q", i) : "q";
    if (!row.not_array.empty() || row.length != static_cast<std::size_t>(dof)) {
      std::string message = f;
      message += " must be an array of " + numbers + ", got ";
      message += row.not_array.empty() ? std::to_string(row.length) + " elements" : row.not_array;
      fail(f, message);
    }
    if (!row.bad_field.empty()) throw InvalidInput(row.bad_field, row.bad_message);
    out.insert(out.end(), row.values.begin(), row.values.end());
  }
  return out;
}

robot::DistanceBatch run_robot_distances(const robot::DistanceModel& model, const std::vector<double>& q, int n, bool validate,
                                         const std::string& robot_field, const std::function<void()>& checkpoint) {
  const auto check = [&] {
    if (checkpoint) checkpoint();
  };
  const auto& pairs = model.pairs();
  if (validate) validate_robot_bodies(model, robot_field, check);

  const int dof = model.dof();
  const std::size_t np = pairs.size();
  const double per_pair = model.metric() == robot::Metric::gap ? model.params().iteration_limit() : 100;
  const auto chunk = static_cast<std::size_t>(std::max(1.0, std::floor(kChunkIterations / (static_cast<double>(std::max<std::size_t>(1, np)) * per_pair))));
  robot::DistanceBatch all;
  all.n = n;
  all.pairs = static_cast<int>(np);
  all.dof = dof;
  std::vector<GapTrack> tracks;
  for (std::size_t begin = 0; begin < static_cast<std::size_t>(n); begin += chunk) {
    check();
    const std::size_t count = std::min(chunk, static_cast<std::size_t>(n) - begin);
    robot::BatchOptions options;
    options.warm_start = tracks;  // the previous chunk's last solutions
    robot::DistanceBatch b = robot::distances(
        model, std::span<const double>(q).subspan(begin * static_cast<std::size_t>(dof), count * static_cast<std::size_t>(dof)),
        static_cast<int>(count), options);
    const auto append = [](auto& to, const auto& from) { to.insert(to.end(), from.begin(), from.end()); };
    append(all.distance, b.distance);
    append(all.jacobian, b.jacobian);
    append(all.witness_robot, b.witness_robot);
    append(all.witness_obstacle, b.witness_obstacle);
    append(all.obstacle_gradient, b.obstacle_gradient);
    append(all.overlap, b.overlap);
    append(all.converged, b.converged);
    append(all.iterations, b.iterations);
    tracks = std::move(b.tracks);
  }
  return all;
}

}  // namespace distlab::server
