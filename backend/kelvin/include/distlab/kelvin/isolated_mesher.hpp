#pragma once
// Parallel meshing in a child process. CGAL 5.5's parallel refinement (MeshingParams::threads > 1)
// crashes its process now and then: SIGSEGV in Regular_triangulation_3 while another thread
// inserts in a neighbouring conflict zone, about 1 in 1,000 small meshings here (upstream:
// CGAL issue #7295, PR #7496, races in Regular_triangulation_3's parallel code). A process that
// holds other work (the server, every client's state) therefore refines on several threads only
// in a child, `exe mesh-domain`: its progress arrives as it goes, a cancellation kills it; a child
// that dies by a signal is run once more, and if that one dies too, or a child answers garbage,
// the mesh is made again in this process on one thread.
#include <iosfwd>
#include <string>
#include <vector>

#include "distlab/kelvin/tet_mesh.hpp"

namespace distlab::kelvin {

// The threads a preparation with PrepareOptions::mesh_threads 0 (chosen) meshes on where it can
// mesh in a child: one (the same mesh bit for bit on every run) below kParallelMeshFrom vertices
// by eq23_vertex_bound, where meshing takes well under a second; the machine's cores above.
inline constexpr double kParallelMeshFrom = 100'000;
int choose_mesh_threads(const MeshingParams& params);

struct IsolatedMeshing {
  std::string warning;               // mesh_inverted_domain's (edge protection given up)
  int threads = 1;                   // the threads the returned mesh was refined on
  std::string retried;               // why the child's mesh was not used and it was meshed here on one thread
  std::vector<std::string> crashes;  // children that died and were run again (each said why)
};

// mesh_inverted_domain(inverted, params) refined by `exe mesh-domain` (exe "": this process's own
// executable, which must be the distlab binary). InvalidInput from the child (a budget) is thrown
// here as it was there; Cancelled when progress is cancelled (the child is killed at once). The
// child's mesh is checked again (counts, finite points, indices in range).
TetMesh mesh_inverted_domain_isolated(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                                      const Progress& progress, IsolatedMeshing& report, const std::string& exe = "");

// The child's side (`distlab mesh-domain`): reads the request at fd 3, writes progress records
// and the mesh or the refusal to out. Returns the exit code.
int mesh_domain_child(const std::vector<std::string>& args, std::ostream& out);

}  // namespace distlab::kelvin
