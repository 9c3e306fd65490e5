#pragma once
// Binary mesh frames: msgpack maps (nlohmann::json::to_msgpack) whose arrays are msgpack "bin"
// values of little-endian float32 positions (x y z per vertex), uint32 indices (3 per
// triangle) and optional float32 per-vertex scalars, next to plain metadata keys. The same bytes
// go out as WebSocket binary messages and as REST downloads (application/msgpack).
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/mesh/surface.hpp"

namespace distlab::server {

nlohmann::json::binary_t float32_bytes(const double* values, std::size_t count);
nlohmann::json::binary_t float32_bytes(const std::vector<double>& values);

// {"n_vertices", "n_faces", "positions", "indices"[, "scalars"]} (+ the given metadata).
nlohmann::json mesh_frame(const mesh::SurfaceMesh& mesh, nlohmann::json meta,
                          const std::vector<double>* scalars = nullptr);

// {"n_vertices", "scalars"} (+ the given metadata): σ per surface vertex without the mesh, for
// every σ version after the surface frame.
nlohmann::json scalars_frame(const std::vector<double>& scalars, nlohmann::json meta);

std::string to_msgpack(const nlohmann::json& frame);

// Reverse of float32_bytes/indices (for tests and the benchmark client).
std::vector<float> read_float32(const nlohmann::json& bin);
std::vector<std::uint32_t> read_uint32(const nlohmann::json& bin);

}  // namespace distlab::server
