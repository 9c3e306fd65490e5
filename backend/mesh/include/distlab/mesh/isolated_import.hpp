#pragma once
// Untrusted mesh files are parsed in a child process (`distlab import-mesh`) with memory, CPU and
// wall-clock limits, so that a fault or a memory bomb in a parser costs that request an error, not
// the server. The child sends the mesh back through a pipe; the parent checks it again.
#include <cstddef>
#include <iosfwd>
#include <string>
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

struct ImportLimits {
  std::size_t memory_bytes = std::size_t{1} << 30;  // RLIMIT_AS of the child
  double seconds = 20;                              // CPU (RLIMIT_CPU) and wall clock
};

// load_mesh(path) run by `exe import-mesh` (exe "": this process's own executable, which must be
// the distlab binary). The result is load_mesh's: file order, checked again here (counts, finite
// coordinates, indices in range). A crash, a timeout or exhausted memory of the child throws
// InvalidInput(field) whose message names the file as `name` (never the path).
SurfaceMesh load_mesh_isolated(const std::string& path, const std::string& field, const std::string& name,
                               const ImportLimits& limits, const std::string& exe = "");

// The same for a file's bytes (an upload) read as `format` (stl, obj, ply, off, glb): they are
// handed to the child as an anonymous in-memory file (memfd), so no temporary file exists in any
// directory, and none is left behind if the server dies during the import.
SurfaceMesh load_bytes_isolated(const std::string& bytes, const std::string& format, const std::string& field,
                                const std::string& name, const ImportLimits& limits, const std::string& exe = "");

// The child's side: args = {path, memory_bytes, seconds[, format]}. Sets its own limits, then writes the
// mesh or the error message to out. Returns the exit code.
int import_mesh_child(const std::vector<std::string>& args, std::ostream& out);

}  // namespace distlab::mesh
