// Inputs of the Kelvin endpoints: levels, the GET level, uploaded bytes and inline meshes
// (kelvin_inputs.hpp).
#include "kelvin_inputs.hpp"

#include <stdexcept>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/isolated_import.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"

namespace distlab::server {

using json = nlohmann::json;

std::vector<double> parse_levels(const json& j, const std::string& field, std::size_t max) {
  if (!j.is_array()) throw InvalidInput(field, field + " must be an array of numbers");
  if (j.size() > max) throw ApiError(413, "too_many_levels", "at most " + std::to_string(max) + " levels", field);
  std::vector<double> out;
  for (std::size_t i = 0; i < j.size(); ++i) out.push_back(json_number(j[i], field + "[" + std::to_string(i) + "]"));
  return out;
}

double query_level(const Request& req) {
  static_assert(kIsosurfaceLevelsPerRequest == 1);
  if (req.repeated_query.count("level"))
    throw ApiError(413, "too_many_levels",
                   "one level per request; for several, PUT .../levels (at most max_levels) and read the "
                   "WebSocket's isosurface frames",
                   "level");
  return query_number(req, "level");
}

mesh::SurfaceMesh load_bytes(const std::string& bytes, const std::string& format, const Limits& limits, double scale) {
  // Parsed in a child process: a parser's crash or memory bomb costs this request a 400.
  mesh::SurfaceMesh m = mesh::load_bytes_isolated(bytes, format, "body", "the uploaded " + format + " file",
                                                  {limits.import_memory_bytes, limits.import_seconds});
  m.vertices *= scale;
  // The coordinate bound of every request (inline meshes too), in the file's vertex numbering.
  for (Eigen::Index i = 0; i < m.vertices.rows(); ++i)
    if (m.vertices.row(i).cwiseAbs().maxCoeff() > kMaxCoordinate)
      throw InvalidInput("body", "vertex " + std::to_string(i) + " of the uploaded " + format +
                                     " file has a coordinate beyond " + json(kMaxCoordinate).dump() +
                                     " metres (in the file's unit times the scale): out of range; give the file's unit (unit=mm, cm or in) or a scale");
  return m;
}

mesh::SurfaceMesh inline_mesh(const json& j, std::size_t max_triangles) {
  if (!j.is_object() || !j.contains("vertices") || !j.contains("faces"))
    throw InvalidInput("mesh", "mesh needs vertices [[x, y, z], ...] and faces [[i, j, k], ...]");
  const json& v = j["vertices"];
  const json& f = j["faces"];
  if (!v.is_array() || v.size() < 4) throw InvalidInput("mesh.vertices", "mesh.vertices must be an array of at least 4 points");
  if (!f.is_array() || f.size() < 4) throw InvalidInput("mesh.faces", "mesh.faces must be an array of at least 4 triangles");
  if (f.size() > max_triangles)
    throw ApiError(413, "too_many_triangles", "at most " + std::to_string(max_triangles) + " triangles", "mesh.faces");
  mesh::SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(v.size()), 3);
  for (std::size_t i = 0; i < v.size(); ++i) {
    const Vec3 p = json_vec3(v[i], "mesh.vertices[" + std::to_string(i) + "]");
    if (p.cwiseAbs().maxCoeff() > kMaxCoordinate) throw InvalidInput("mesh.vertices[" + std::to_string(i) + "]", "coordinate out of range");
    m.vertices.row(static_cast<Eigen::Index>(i)) = p.transpose();
  }
  m.faces.resize(static_cast<Eigen::Index>(f.size()), 3);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const std::string field = "mesh.faces[" + std::to_string(i) + "]";
    if (!f[i].is_array() || f[i].size() != 3) throw InvalidInput(field, field + " must be 3 vertex indices");
    for (int c = 0; c < 3; ++c) {
      const json& x = f[i][static_cast<std::size_t>(c)];
      if (!x.is_number_integer() || x.get<std::int64_t>() < 0 || x.get<std::int64_t>() >= static_cast<std::int64_t>(v.size()))
        throw InvalidInput(field, field + " has an index out of range");
      m.faces(static_cast<Eigen::Index>(i), c) = static_cast<int>(x.get<std::int64_t>());
    }
  }
  return m;
}

}  // namespace distlab::server
