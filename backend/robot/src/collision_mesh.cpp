#include "collision_mesh.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cstdint>
#include <unordered_map>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/weld.hpp"

namespace distlab::robot {
namespace {

bool has_dot_dot(const std::string& path) {
  std::size_t start = 0;
  while (start <= path.size()) {
    const std::size_t end = std::min(path.find('/', start), path.size());
    if (path.compare(start, end - start, "..") == 0 && end - start == 2) return true;
    start = end + 1;
  }
  return false;
}

// The first edge used by one face only (welded positions), or "" for a closed surface.
std::string open_edge(const mesh::SurfaceMesh& m) {
  std::unordered_map<std::uint64_t, int> uses;
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int e = 0; e < 3; ++e) {
      const auto a = static_cast<std::uint64_t>(m.faces(f, e)), b = static_cast<std::uint64_t>(m.faces(f, (e + 1) % 3));
      ++uses[std::min(a, b) << 32 | std::max(a, b)];
    }
  std::size_t open = 0;
  for (const auto& [key, n] : uses) open += n == 1;
  if (open == 0) return "";
  return std::to_string(open) + " edges belong to one face only (the surface has holes)";
}

}  // namespace

std::string resolve_mesh_path(const std::string& filename, const UrdfOptions& options, const std::string& field) {
  if (filename.empty()) throw InvalidInput(field, "robot URDF: mesh filename is empty");
  const std::string package = "package://", file = "file://";
  if (filename.rfind(package, 0) == 0) {
    // "package:///NAME/..." (an extra slash, seen in public descriptions) is read as package://NAME/...
    const std::size_t start = filename.find_first_not_of('/', package.size());
    const std::string rest = start == std::string::npos ? "" : filename.substr(start);  // "package://" alone
    const std::size_t slash = rest.find('/');
    const std::string name = rest.substr(0, slash);
    const std::string inside = slash == std::string::npos ? "" : rest.substr(slash + 1);
    if (name.empty() || inside.empty() || has_dot_dot(inside))
      throw InvalidInput(field, "robot URDF: mesh \"" + filename.substr(0, 200) +
                                    "\" must name a file inside its package: package://NAME/path (no \"..\")");
    if (const auto it = options.package_dirs.find(name); it != options.package_dirs.end()) return it->second + "/" + inside;
    for (const std::string& dir : options.package_search_dirs) {
      std::string path = dir;
      path.append("/").append(name).append("/").append(inside);
      struct stat st {};
      if (::stat(path.c_str(), &st) == 0) return path;
    }
    throw InvalidInput(field, "robot URDF: mesh \"" + filename.substr(0, 200) + "\": package \"" + name.substr(0, 64) +
                                  "\" is not in package_dirs" +
                                  (options.package_search_dirs.empty() ? "" : " nor below package_search_dirs"));
  }
  if (filename.rfind(file, 0) == 0) return filename.substr(file.size());
  if (filename.front() == '/') return filename;
  if (filename.find("://") != std::string::npos)
    throw InvalidInput(field, "robot URDF: mesh \"" + filename.substr(0, 200) + "\": only package://, file:// and paths are read");
  if (options.base_dir.empty())
    throw InvalidInput(field, "robot URDF: mesh \"" + filename.substr(0, 200) +
                                  "\" is relative, and the URDF has no folder (give package:// or an absolute path)");
  return options.base_dir + "/" + filename;
}

Polytope mesh_hull(const std::string& filename, const Vec3& scale, const UrdfOptions& options, const std::string& field,
                   std::string& warning) {
  const std::string path = resolve_mesh_path(filename, options, field);
  const std::string what = "robot URDF: mesh \"" + filename.substr(0, 200) + "\"";
  mesh::SurfaceMesh m;
  if (options.read_mesh) {
    m = options.read_mesh(filename, path, field);
  } else {
    struct stat st {};
    // The local reader (Python, the CLI; the server's uploads come through read_mesh): the path it
    // looked at is the user's own, and a package folder that is not there is the likelier mistake.
    if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) {
      const auto quoted = [](const std::string& text) { return "\"" + text.substr(0, 300) + "\""; };
      const std::string folder = path.substr(0, path.find_last_of('/') + 1);
      struct stat dir {};
      const bool no_folder = !folder.empty() && (::stat(folder.c_str(), &dir) != 0 || !S_ISDIR(dir.st_mode));
      const std::string reason = S_ISDIR(st.st_mode) ? "a folder, not a file"
                                 : no_folder         ? "no such file: its folder " + quoted(folder) + " does not exist"
                                                     : "no such file";
      throw InvalidInput(field, what + ", read from " + quoted(path) + ": " + reason);
    }
    try {
      m = mesh::load_mesh(path, field);
    } catch (const InvalidInput& e) {
      throw InvalidInput(field, what + ": " + e.what());
    }
  }
  if (static_cast<std::size_t>(m.vertices.rows()) > options.limits.mesh_vertices)
    throw InvalidInput(field, what + ": more than " + std::to_string(options.limits.mesh_vertices) + " vertices");
  if (m.faces.rows() == 0) throw InvalidInput(field, what + ": has no faces");
  const mesh::Welded welded = mesh::weld(m);
  if (const std::string defect = open_edge(welded.surface); !defect.empty()) {
    if (options.require_closed_meshes) throw InvalidInput(field, what + " is not closed: " + defect);
    warning = what + " is not closed (" + defect + "): its vertices' convex hull is used";
  }
  std::vector<Vec3> points(static_cast<std::size_t>(welded.surface.vertices.rows()));
  for (std::size_t i = 0; i < points.size(); ++i)
    points[i] = Vec3(welded.surface.vertices.row(static_cast<Eigen::Index>(i))).cwiseProduct(scale);
  Polytope hull;
  try {
    hull = polytope_from_points(points, "mesh");
  } catch (const InvalidInput& e) {
    throw InvalidInput(field, what + " is degenerate: " + e.what());
  }
  if (hull.rows() > options.limits.mesh_hull_rows)
    throw InvalidInput(field, what + ": its convex hull has " + std::to_string(hull.rows()) + " facets, more than " +
                                  std::to_string(options.limits.mesh_hull_rows) + " (simplify the collision mesh)");
  return hull;
}

}  // namespace distlab::robot
