#pragma once
// The tetrahedralised inverted domain Ω_inv ∪ {0} (Section IV-C) in y-coordinates.
#include <Eigen/Core>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "distlab/geometry/types.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::kelvin {

using TetsX4 = Eigen::Matrix<int, Eigen::Dynamic, 4, Eigen::RowMajor>;

// Every finite cell of the mesher's triangulation (it covers the convex hull, so point location
// can walk across concavities); in_domain marks the cells of Ω_inv. Cells are positively
// oriented; neighbours(c, i) is the cell opposite vertex i, or -1 on the hull.
struct TetMesh {
  MatX3 points;
  TetsX4 tets;
  TetsX4 neighbours;
  std::vector<std::uint8_t> in_domain;
};

struct MeshingParams {
  double lx = 0.1;              // exterior element size l_x (eq. 23)
  double min_size = 0.0;        // lower bound of the interior sizing field l_y
  double feature_angle = 60.0;  // sharp edges: eq. 23 protects them, the graded sizing refines near them
  // 0: l_y = max(|y|² l_x, min_size) (eq. 23, uniform in x). g > 0, the graded sizing:
  // l_y = s_e · max(|y|² l_x + g · d_y, min_size), d_y the distance in y from the inverted surface
  // (coarser away from the object, where V is smooth) and s_e = max(√(e_x / (kGradedEdgeRadius
  // l_x)), kGradedEdgeFloor) ≤ 1, e_x the distance in x from the sharp edges (feature_angle):
  // finer where the solution is singular, which is where the cube's capacitance error sits.
  double grading = 0.0;
  // Longest edge (in x) of the surface polyhedron handed to Mesh_3; 0: lx.
  double boundary_edge_length = 0.0;
  // Limits that turn a runaway refinement into an error instead of a hang (deterministic: counts,
  // not wall time). See PrepareOptions.
  std::size_t max_vertices = 2'000'000;
  double max_protection_evaluations = 2e5;  // edge-sizing evaluations while protecting edges
  double max_refinement_evaluations = 1e8;  // facet/cell sizing evaluations while refining
  // 1: one thread, the same mesh bit for bit on every run. n > 1: CGAL's parallel refinement
  // (Parallel_tag, TBB) on n threads, faster, but the mesh (and its vertex count, by a few
  // percent) differs from run to run: the field is reproducible to the mesh's accuracy, not bits.
  int threads = 1;
  // The vertices predicted (predict_vertices; 0: none): refinement reports its progress between
  // 0.1 and 0.9 by its sizing evaluations against expected_vertices × kSizingCallsPerVertex.
  double expected_vertices = 0;
};

// Mesh_3 evaluates the sizing ~23 times per vertex it keeps (DISTLAB_MESH_DEBUG on the cube at l_x
// 0.03: eq. 23 2.53M for 118k vertices, 21.4; graded 2.30M for 95.8k, 24.0).
inline constexpr double kSizingCallsPerVertex = 23;

// The graded sizing's refinement near sharp edges: within kGradedEdgeRadius · l_x of an edge (in
// x) the size falls as √(distance), to kGradedEdgeFloor times the ungraded size. The radius
// scales with l_x, so the added vertices grow like the edges' length / l_x², not as a volume.
inline constexpr double kGradedEdgeRadius = 4.0;
inline constexpr double kGradedEdgeFloor = 0.25;

// Predicted vertex counts of eq. 23's sizing and of the graded one (params.grading > 0) on the
// same inverted surface, before meshing (PrepareOptions::grading's automatic choice). Mesh_3
// places about kVerticesPerSizingIntegral vertices per unit of ∫ dV_y / l_y³ over Ω_inv
// (quadrature on rays from y = 0, the domain's inside test and the graded sizing's own
// surface distance); the graded sizing's refinement near sharp edges (feature_angle < 180) adds
// kGradedEdgeVerticesTypical · (their length in x) / l_x.
struct SizingPrediction {
  double paper = 0;   // eq. 23 (grading 0)
  double graded = 0;  // params.grading
  // The model's parts: ∫ dV_y / l_y³ over Ω_inv of both sizings, ∫ dA_y / l_y² over the inverted
  // surface (the same for both: the graded sizing adds nothing on the surface), the sharp edges'
  // length in x (feature_angle; 0 if 180).
  double volume_paper = 0, volume_graded = 0, surface = 0, edge_length = 0;
};
SizingPrediction predict_vertices(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                                  const Progress& progress = {});
// Fitted on the cube with eq. 23 (l_x 0.05–0.02: 0.74–0.71, the finest last; coarser meshes
// have relatively more surface vertices) and checked on the wrench and the knife (notes of issue 19).
inline constexpr double kVerticesPerSizingIntegral = 0.71;
// Vertices per metre of sharp edge per 1/l_x (feature_angle 60 against 180): the cube 62–72 (l_x
// 0.15–0.03), the wrench 62 (l_x 0.002, centre 0), the knife 57 (l_x 0.02); the server's vertex
// budget counts the upper bound kGradedEdgeVerticesPerLength (surface_tools.hpp).
inline constexpr double kGradedEdgeVerticesTypical = 64;
// Vertices per unit of SizingPrediction::surface (∫ dA_y / l_y² over the inverted surface) beyond
// the volume term, both sizings: fitted on the sphere (204–9.6k vertices at l_x 0.15–0.035, where
// the volume term alone is 54–90% of the count) and checked on the cube and wraps without edge
// protection (issue 37). Not part of choose_grading's comparison, which is as it was.
inline constexpr double kSurfaceVerticesPerSizingIntegral = 0.45;

// The sizing PrepareOptions::grading chooses when not given: the graded sizing kAutoGrading
// (goal 3's table of issue 19: at l_x 0.02 on the cube 185k vertices against eq. 23's 394k, more
// accurate) where predict_vertices gives it at most kAutoGradedShare of eq. 23's vertices, else
// eq. 23 (0). Its meshing costs about twice as much per vertex (the distance searches: cube at
// l_x 0.03, 17.1 s for 94k vertices against 7.6 s for 118k), so a small saving is not taken.
// Below kAutoPredictFrom vertices by eq. 23's closed-form bound it is eq. 23 without a
// prediction, which costs 0.06–0.25 s (as much as meshing such a field); above, it can pay many
// times over (the knife at l_x 0.02: 6.7k vertices against 17k).
inline constexpr double kAutoGrading = 0.05;
inline constexpr double kAutoGradedShare = 2.0 / 3.0;
inline constexpr double kAutoPredictFrom = 5'000;
// *prediction (if given) receives predict_vertices' counts when the choice made one (at or above
// kAutoPredictFrom; its graded count is kAutoGrading's), and is left alone otherwise.
double choose_grading(const mesh::SurfaceMesh& inverted, const MeshingParams& params, const Progress& progress = {},
                      SizingPrediction* prediction = nullptr);

// Eq. 23's closed-form bound on the vertex count: ∫ dV_y / l_y³ is at most twice
// (4/3)π / (ρ l_x)³, ρ = √(min_size / l_x) where l_y reaches min_size.
double eq23_vertex_bound(const MeshingParams& params);

// CGAL Mesh_3 on the region bounded by the (already inverted, outward-oriented) surface with
// l_y(y) of MeshingParams::grading (eq. 23 when grading is 0). Deterministic: fixed seeds, no time limits.
// Eq. 23 protects the sharp edges (feature_angle < 180); if that exceeds its step budget (thin
// features), meshes again without it and sets *warning. The graded sizing protects none. Exceeding the vertex or refinement budget throws InvalidInput("lx", …).
TetMesh mesh_inverted_domain(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                             const Progress& progress, std::string* warning = nullptr);

// The surface Mesh_3 meshes for these params: the inverted surface with its edges bisected in x
// to params.boundary_edge_length (l_x if 0), in y. For a baseline on the same surface
// (distlab-bench-kelvin --mesher).
mesh::SurfaceMesh meshing_surface(const mesh::SurfaceMesh& inverted, const MeshingParams& params);

// Makes the boundary of the domain cells a closed 2-manifold: at every vertex, the domain cells
// around it and the other cells (the hull counting as one) each form one face-connected piece.
// Where two parts of the domain meet at an edge or a vertex only, the smaller parts' cells around
// it leave the domain (the object grows by them). Returns how many cells left it.
long make_boundary_manifold(TetMesh& tm);

}  // namespace distlab::kelvin
