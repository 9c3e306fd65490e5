// Kelvin object endpoints: objects (prepared as a job), σ, levels, queries, iso-surfaces (msgpack
// frames as downloads), exports; the uploads are routes_kelvin_uploads.cpp's. Their codec is
// kelvin_codec.cpp, their handlers kelvin_service.cpp (creation) and kelvin_object_handlers.cpp.
#include "distlab/server/route_table.hpp"
#include "kelvin_codec.hpp"
#include "kelvin_module.hpp"

namespace distlab::server {

void KelvinModule::register_routes() {
  register_upload_routes();

  using M = KelvinModule;
  const std::vector<std::string> iso_bounds = {"max_vertex_estimate", "isosurface_levels_per_request"};
  // A row per route, as a table.
  // clang-format off
  add_routes<M>(router_, *this, config_.limits, {
    {"POST", "/api/kelvin/objects", Work::heavy, {"max_body_bytes", "max_upload_triangles", "max_object_triangles", "max_held_triangles_per_address", "max_held_triangles", "min_lx", "max_vertex_estimate", "max_objects_per_session", "max_jobs_per_session", "max_jobs_total", "max_hole_edges", "max_repair_faces"},
     codec(decode_create_object, &M::create_object, encode_created_object)},
    {"POST", "/api/kelvin/estimate", Work::heavy, {"max_body_bytes", "max_upload_triangles", "max_object_triangles", "min_lx", "max_vertex_estimate"},
     codec(decode_create_object, &M::estimate, encode_estimate)},
    {"GET", "/api/kelvin/objects", Work::light, {}, codec(decode_nothing, &M::list_objects, encode_object_list)},
    {"GET", "/api/kelvin/objects/{id}", Work::light, {}, codec(decode_object_ref, &M::get_object, encode_object)},
    {"DELETE", "/api/kelvin/objects/{id}", Work::light, {}, codec(decode_object_ref, &M::delete_object, encode_deleted)},
    {"GET", "/api/kelvin/objects/{id}/sigma", Work::light, {}, codec(decode_object_ref, &M::get_sigma, encode_sigma)},
    {"PUT", "/api/kelvin/objects/{id}/sigma", Work::light, {}, codec(decode_put_sigma, &M::put_sigma, encode_sigma)},
    {"PUT", "/api/kelvin/objects/{id}/levels", Work::light, {}, codec(decode_put_levels, &M::put_levels, encode_levels)},
    {"POST", "/api/kelvin/objects/{id}/query", Work::heavy, {"max_body_bytes", "max_query_points", "max_request_seconds"},
     codec(decode_query, &M::query, encode_query)},
    {"GET", "/api/kelvin/objects/{id}/isosurface", Work::heavy, iso_bounds, codec(decode_isosurface, &M::isosurface, encode_isosurface)},
    {"GET", "/api/kelvin/objects/{id}/surface", Work::light, {}, codec(decode_surface, &M::surface, encode_surface)},
    {"GET", "/api/kelvin/objects/{id}/export", Work::heavy, iso_bounds, codec(decode_export, &M::export_isosurface, encode_export)},
  });
  // clang-format on
}

}  // namespace distlab::server
