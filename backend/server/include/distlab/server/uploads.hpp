#pragma once
// The meshes a session uploaded (POST /api/kelvin/uploads), by upload id. Their bytes were parsed
// in an isolated child process (mesh/isolated_import.hpp) when they arrived: every module that
// takes an upload id (Kelvin objects, a robot's URDF meshes) reads the parsed surface from here
// and never parses the bytes itself.
#include <cstddef>
#include <map>
#include <memory>
#include <string>

#include "distlab/mesh/surface.hpp"
#include "distlab/server/client_share.hpp"
#include "distlab/server/session.hpp"

namespace distlab::server {

struct Upload {
  mesh::SurfaceMesh surface;  // the file's vertices in its order, times the upload's unit or scale
  std::string format;
  std::size_t bytes = 0;
  std::string unit;  // "m", "cm", "mm", "in", or "" when a scale was given
  double scale = 1;  // metres per file unit
  // SHA-256 of `surface` (kelvin::surface_digest): what a link names the mesh by.
  std::string digest;
};

// A session's uploads (Session::state, guarded by the session's mutex), at most
// Limits::max_uploads_per_session, each with its reservation of held triangles (client_share.hpp).
struct SessionUploads : ModuleState {
  std::map<std::string, std::shared_ptr<const Upload>> uploads;
  std::map<std::string, ClientShare::Reservation> held;  // triangles, in the client's share
};

}  // namespace distlab::server
