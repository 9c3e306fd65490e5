#pragma once
// Configuration of the service: directories and every explicit limit (all enforced with a 4xx).
#include <cstddef>
#include <string>

#include "distlab/robot/description_limits.hpp"

namespace distlab::server {

// GET /api/kelvin/objects/{id}/isosurface and .../export extract one level each (a repeated level
// is 413 too_many_levels); several levels at once go through PUT .../levels, bounded by max_levels.
inline constexpr std::size_t kIsosurfaceLevelsPerRequest = 1;

struct Limits {
  std::size_t max_body_bytes = std::size_t{8} << 20;  // JSON requests
  // Mesh uploads: scans of up to max_upload_triangles are read (a binary STL of 2M triangles is
  // 100 MB, parsed by the importer's child in ~340 MB). A preparation takes a surface of at most
  // max_object_triangles: a bigger one is simplified ("simplify": {"faces": N}) or wrapped first.
  std::size_t max_upload_bytes = std::size_t{128} << 20;
  std::size_t max_upload_triangles = 2000000;
  std::size_t max_object_triangles = 200000;
  std::size_t max_uploads_per_session = 8;
  // The triangles the server holds for clients (every upload a session keeps, and every Kelvin
  // object's input surface: ~100 bytes each), per client address and in all; over either, a new
  // upload or object is refused (413 for the address, 503 for the server) until some are deleted.
  std::size_t max_held_triangles_per_address = 6000000;
  std::size_t max_held_triangles = 24000000;
  double min_lx = 0.002;  // absolute floor of l_x, metres (the paper's wrench cases)
  // Vertex budget of one prepared object, as estimated (estimate_vertices): the wrench at l_x 0.002
  // is estimated at ~301k (84k made), so the paper's cases fit.
  std::size_t max_vertex_estimate = 320000;
  std::size_t max_sessions = 1000;
  std::size_t max_sessions_per_address = 32;  // one client address cannot hold the others' sessions
  double session_idle_seconds = 3600;
  std::size_t max_objects_per_session = 16;
  std::size_t max_jobs_per_session = 4;     // queued + running
  std::size_t max_jobs_total = 16;          // queued + running, all sessions
  std::size_t max_finished_jobs_kept = 64;  // per session; older finished jobs are forgotten
  double max_job_seconds = 600;             // a job running longer is cancelled
  double max_request_seconds = 30;          // cancellable request work stops after this (408)
  std::size_t max_pending_requests = 256;   // compute queue; beyond it 503 busy
  std::size_t max_ws_message_bytes = std::size_t{1} << 20;
  double ws_messages_per_second = 50;  // token bucket rate ...
  double ws_burst = 100;               // ... and depth; empty bucket: error, then close
  std::size_t max_ws_queue = 256;      // outgoing messages queued for a slow client
  std::size_t max_query_points = 100000;
  std::size_t max_levels = 16;
  int max_grid_resolution = 128;
  int max_plane_resolution = 512;
  std::size_t max_gap_pairs = 2000;
  int max_gap_iterations = 1000000;  // params.max_iter of one GAP pair (0: the solver's default)
  // GAP shapes, so that one shape cannot pin the parser and the P2S build: rows (and weights) of a
  // polytope and facets of a convex_hull's hull; input points of a convex_hull. grid.padding of
  // POST /api/gap/levelsets, relative to the shape's bounding radius: beyond it the grid box is no
  // longer a picture of the shape (and 1e300 reached infinite coordinates).
  std::size_t max_polytope_rows = 1000;
  std::size_t max_hull_points = 100000;
  double max_grid_padding = 100;
  std::size_t query_chunk_points = 4096;  // Kelvin queries check the time limit this often
  // POST /api/robot/distances: configurations, configurations × pairs (each a distance, two
  // witnesses and a dof-long gradient: ~350 bytes of JSON for 7 joints, so ~18 MB at the limit),
  // and obstacles (each built and checked for Property 2 once per request).
  std::size_t max_robot_configurations = 10000;
  std::size_t max_robot_pair_evaluations = 50000;
  std::size_t max_robot_obstacles = 256;
  // A URDF's description (robot::DescriptionLimits, whose defaults these are): its text's bytes,
  // links, joints and collision elements, and one mesh's vertices and hull facets (each facet a
  // row of the GAP polytope every configuration evaluates).
  std::size_t max_urdf_bytes = robot::kMaxUrdfBytes;
  int max_robot_links = robot::kMaxLinks;
  int max_robot_joints = robot::kMaxJoints;
  int max_robot_collision_elements = robot::kMaxCollisionElements;
  int max_robot_mesh_hull_facets = robot::kMaxMeshHullRows;
  std::size_t max_robot_mesh_vertices = robot::kMaxMeshVertices;
  // CBF rollouts: a rollout's steps (duration / dt) and seconds of simulated time; its collision
  // pairs × steps, kept in memory (≈ 80 bytes each); a scenario's obstacles (each a pair per
  // robot primitive, built per step); steps per "cbf_frames" message and per GET .../frames;
  // runs of one sweep. Rollouts kept per session and in all (older ended ones are forgotten; the
  // total also bounds the sweeps kept), and those that keep their prepared Kelvin fields once
  // their job ended (a field is large: wrench_grasp's run peaks at 0.4 GB, 20 MB without). A
  // scenario's Kelvin objects (each prepared, and a QP row per control point per step) and control
  // points (sampled ones counted).
  int max_cbf_steps = 20000;
  double max_cbf_duration = 600;
  std::size_t max_cbf_pair_steps = 1000000;
  std::size_t max_cbf_obstacles = 1000;
  int max_cbf_batch_steps = 500;
  std::size_t max_cbf_frames_per_request = 2000;
  std::size_t max_cbf_sweep_values = 16;
  std::size_t cbf_rollouts_kept_per_session = 4;
  std::size_t cbf_rollouts_kept_total = 32;
  std::size_t cbf_fields_kept_total = 2;
  std::size_t max_cbf_fields = 8;
  std::size_t max_cbf_control_points = 1024;
  // Connections: beyond max_connections a new one is closed at once; a client that sends no
  // complete header (idle or slowloris) or body within read_timeout_seconds is closed.
  std::size_t max_connections = 512;
  double read_timeout_seconds = 30;
  // An upload is parsed in a child process (distlab import-mesh) with this address-space limit
  // and this CPU and wall-clock time; beyond either it is refused (400, field body).
  std::size_t import_memory_bytes = std::size_t{1} << 30;
  double import_seconds = 20;
  // "repair": "fix" fills holes of at most max_hole_edges edges; "wrap" is estimated before it
  // runs (mesh::estimate_wrap: faces, memory, seconds from the input's faces and area, α and the
  // offset) and refused up front (422, field repair_options.alpha, naming the α that fits) when
  // over max_repair_faces, max_repair_bytes or max_repair_seconds; while it runs, more Steiner
  // points than max_repair_faces stop it (a cancel too). The 2CylinderEngine CAD part at
  // α = diagonal / 200 makes 144k faces in 29 s and 342 MB.
  std::size_t max_hole_edges = 1000;
  std::size_t max_repair_faces = 200000;
  std::size_t max_repair_bytes = std::size_t{1} << 30;
  double max_repair_seconds = 300;
  // GET /api/kelvin/uploads/{id}/defects lists at most this many of each defect (edges, vertices,
  // faces, intersecting pairs, a piece's face runs); the counts are whole.
  std::size_t max_defect_items = 10000;
  // Each preparation gets its boundary response (kelvin/field.hpp: strokes at ~0.2× a full solve
  // instead of ~0.8×) if it takes at most max_response_bytes and all live preparations' responses
  // stay within max_response_bytes_total; otherwise strokes are solved with the factor. The
  // response is n_interior × n_boundary doubles: 461 MB for the cube at l_x 0.05 (26k vertices,
  // factor 72 MB). Same field to rounding either way. First come first served; fields that no
  // object holds any more (kept for reuse) give theirs up when a preparation needs the room.
  std::size_t max_response_bytes = std::size_t{512} << 20;
  std::size_t max_response_bytes_total = std::size_t{1} << 30;
  // The user's own scene items (Client.scene, routes_scene.cpp): per session at most this many
  // items, of at most max_scene_vertices vertices each, max_scene_bytes of frames together.
  std::size_t max_scene_items = 64;
  std::size_t max_scene_vertices = 1000000;
  std::size_t max_scene_bytes = std::size_t{64} << 20;
  // Client.record: one recording per session of at most max_record_seconds (video) or
  // max_record_frames (PNG), at most max_record_fps, held in memory up to max_record_bytes.
  double max_record_seconds = 60;
  std::size_t max_record_frames = 600;
  double max_record_fps = 60;
  std::size_t max_record_bytes = std::size_t{256} << 20;
  // The bytes the server holds for clients in scene items and recordings, per client address and
  // in all (as max_held_triangles for meshes): 413 too_much_held, 503 busy.
  std::size_t max_held_bytes_per_address = std::size_t{1} << 30;
  std::size_t max_held_bytes = std::size_t{4} << 30;
  // The field store (--cache-dir, kelvin/store.hpp), which servers, the CLI and Dask workers may
  // share: after writing an entry the server evicts the least recently used ones until the
  // entries take at most max_cache_bytes (0: no budget; entries used in the last minute are kept).
  // A preparation's lease on its entry is renewed every cache_lease_seconds / 4; another process
  // takes a lease over that it has not seen renewed for cache_lease_seconds (at once when its
  // holder was a process of the same machine that is gone).
  std::size_t max_cache_bytes = std::size_t{16} << 30;
  double cache_lease_seconds = 60;
};

// The one table of limits: f(name, field) for each field of Limits (L: Limits or const Limits).
// GET /api/limits, the OpenAPI bounds ("x-limit" annotations) and `distlab serve --limit
// NAME=VALUE` are all generated from it.
template <class L, class F>
void for_each_limit(L& l, F&& f) {
  f("max_body_bytes", l.max_body_bytes);
  f("max_upload_bytes", l.max_upload_bytes);
  f("max_upload_triangles", l.max_upload_triangles);
  f("max_object_triangles", l.max_object_triangles);
  f("max_uploads_per_session", l.max_uploads_per_session);
  f("max_held_triangles_per_address", l.max_held_triangles_per_address);
  f("max_held_triangles", l.max_held_triangles);
  f("min_lx", l.min_lx);
  f("max_vertex_estimate", l.max_vertex_estimate);
  f("max_sessions", l.max_sessions);
  f("max_sessions_per_address", l.max_sessions_per_address);
  f("session_idle_seconds", l.session_idle_seconds);
  f("max_objects_per_session", l.max_objects_per_session);
  f("max_jobs_per_session", l.max_jobs_per_session);
  f("max_jobs_total", l.max_jobs_total);
  f("max_finished_jobs_kept", l.max_finished_jobs_kept);
  f("max_job_seconds", l.max_job_seconds);
  f("max_request_seconds", l.max_request_seconds);
  f("max_pending_requests", l.max_pending_requests);
  f("max_ws_message_bytes", l.max_ws_message_bytes);
  f("ws_messages_per_second", l.ws_messages_per_second);
  f("ws_burst", l.ws_burst);
  f("max_ws_queue", l.max_ws_queue);
  f("max_query_points", l.max_query_points);
  f("max_levels", l.max_levels);
  f("max_grid_resolution", l.max_grid_resolution);
  f("max_plane_resolution", l.max_plane_resolution);
  f("max_gap_pairs", l.max_gap_pairs);
  f("max_gap_iterations", l.max_gap_iterations);
  f("max_polytope_rows", l.max_polytope_rows);
  f("max_hull_points", l.max_hull_points);
  f("max_grid_padding", l.max_grid_padding);
  f("query_chunk_points", l.query_chunk_points);
  f("max_robot_configurations", l.max_robot_configurations);
  f("max_robot_pair_evaluations", l.max_robot_pair_evaluations);
  f("max_robot_obstacles", l.max_robot_obstacles);
  f("max_urdf_bytes", l.max_urdf_bytes);
  f("max_robot_links", l.max_robot_links);
  f("max_robot_joints", l.max_robot_joints);
  f("max_robot_collision_elements", l.max_robot_collision_elements);
  f("max_robot_mesh_hull_facets", l.max_robot_mesh_hull_facets);
  f("max_robot_mesh_vertices", l.max_robot_mesh_vertices);
  f("max_cbf_steps", l.max_cbf_steps);
  f("max_cbf_duration", l.max_cbf_duration);
  f("max_cbf_pair_steps", l.max_cbf_pair_steps);
  f("max_cbf_obstacles", l.max_cbf_obstacles);
  f("max_cbf_batch_steps", l.max_cbf_batch_steps);
  f("max_cbf_frames_per_request", l.max_cbf_frames_per_request);
  f("max_cbf_sweep_values", l.max_cbf_sweep_values);
  f("cbf_rollouts_kept_per_session", l.cbf_rollouts_kept_per_session);
  f("cbf_rollouts_kept_total", l.cbf_rollouts_kept_total);
  f("cbf_fields_kept_total", l.cbf_fields_kept_total);
  f("max_cbf_fields", l.max_cbf_fields);
  f("max_cbf_control_points", l.max_cbf_control_points);
  f("max_connections", l.max_connections);
  f("read_timeout_seconds", l.read_timeout_seconds);
  f("import_memory_bytes", l.import_memory_bytes);
  f("import_seconds", l.import_seconds);
  f("max_hole_edges", l.max_hole_edges);
  f("max_repair_faces", l.max_repair_faces);
  f("max_repair_bytes", l.max_repair_bytes);
  f("max_repair_seconds", l.max_repair_seconds);
  f("max_defect_items", l.max_defect_items);
  f("max_response_bytes", l.max_response_bytes);
  f("max_response_bytes_total", l.max_response_bytes_total);
  f("max_scene_items", l.max_scene_items);
  f("max_scene_vertices", l.max_scene_vertices);
  f("max_scene_bytes", l.max_scene_bytes);
  f("max_record_seconds", l.max_record_seconds);
  f("max_record_frames", l.max_record_frames);
  f("max_record_fps", l.max_record_fps);
  f("max_record_bytes", l.max_record_bytes);
  f("max_held_bytes_per_address", l.max_held_bytes_per_address);
  f("max_held_bytes", l.max_held_bytes);
  f("max_cache_bytes", l.max_cache_bytes);
  f("cache_lease_seconds", l.cache_lease_seconds);
}

// The description limits of the table, as the robot library takes them (UrdfOptions::limits).
inline robot::DescriptionLimits description_limits(const Limits& l) {
  return {l.max_urdf_bytes, l.max_robot_links, l.max_robot_joints, l.max_robot_collision_elements, l.max_robot_mesh_hull_facets,
          l.max_robot_mesh_vertices};
}

struct ServiceConfig {
  std::string web_dir = "web/dist";
  std::string assets_dir = "assets";
  std::string cache_dir;         // "" : a temporary directory
  unsigned compute_threads = 0;  // 0: hardware concurrency
  unsigned job_threads = 0;      // 0: hardware concurrency
  // The distlab executable whose `mesh-domain` command meshes big fields on every core in a child
  // process (PrepareOptions::mesh_worker; `distlab serve` sets its own); "": one thread here, and
  // mesh_threads > 1 is refused.
  std::string mesh_worker;
  Limits limits;
};

}  // namespace distlab::server
