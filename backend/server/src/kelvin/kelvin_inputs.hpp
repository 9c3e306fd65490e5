#pragma once
// Inputs of the Kelvin endpoints that are not the σ codec (kelvin_json.hpp): mesh sources (asset
// extensions, uploaded bytes, inline meshes), iso-levels, and the one level of a GET.
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/mesh/surface.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace distlab::server {

// An array of at most max finite numbers; more is 413 too_many_levels.
std::vector<double> parse_levels(const nlohmann::json& j, const std::string& field, std::size_t max);

// The one level of GET .../isosurface and .../export (kIsosurfaceLevelsPerRequest): several levels
// are refused with the field, pointing to PUT .../levels (max_levels), whose frames carry them all.
double query_level(const Request& req);

// Reads uploaded mesh bytes (an anonymous in-memory file, never a file in a directory) in a child
// process limited by limits.import_memory_bytes and import_seconds. Vertices in the file's order,
// multiplied by scale (metres per file unit).
mesh::SurfaceMesh load_bytes(const std::string& bytes, const std::string& format, const Limits& limits, double scale = 1.0);

// {"vertices": [[x, y, z], ...], "faces": [[i, j, k], ...]} (field "mesh"), at most max_triangles.
mesh::SurfaceMesh inline_mesh(const nlohmann::json& j, std::size_t max_triangles);

}  // namespace distlab::server
