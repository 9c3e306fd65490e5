// The Kelvin upload routes' codec: their inputs checked once, their answers written.
#include "kelvin_upload_codec.hpp"

#include <algorithm>
#include <utility>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/checks.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/json_fields.hpp"
#include "distlab/server/request_params.hpp"
#include "kelvin_inputs.hpp"

namespace distlab::server {

using json = nlohmann::json;

namespace {

// A digest as the API writes it: 64 lower-case hex digits (kelvin::Sha256::hex).
std::string valid_digest(const std::string& text, const std::string& field) {
  const bool ok = text.size() == 64 && std::all_of(text.begin(), text.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
  if (!ok) throw InvalidInput(field, field + " must be 64 lower-case hex digits (an upload's digest)");
  return text;
}

ApiError too_many_triangles(const Limits& limits) {
  return {413, "too_many_triangles", "at most " + std::to_string(limits.max_upload_triangles) + " triangles", "body"};
}

// The query's format (stl, obj, ply, glb, off); the body must not be empty.
std::string upload_format(const Request& req) {
  const auto it = req.query.find("format");
  if (it == req.query.end()) throw InvalidInput("format", "query parameter format is required (stl, obj, ply, glb, off)");
  const std::string& format = it->second;
  if (format != "stl" && format != "obj" && format != "ply" && format != "glb" && format != "off")
    throw InvalidInput("format", "format must be stl, obj, ply, glb or off");
  if (req.body.empty()) throw ApiError(400, "empty_body", "the upload is empty");
  return format;
}

// The file's unit: a name ("m", "cm", ...) or a factor to metres (unit ""), not both; metres by
// default.
void upload_unit(const Request& req, UploadFile& file) {
  if (req.query.count("unit") && req.query.count("scale")) throw InvalidInput("scale", "give unit or scale, not both");
  file.scale = 1.0;
  file.unit = "m";
  if (const auto u = req.query.find("unit"); u != req.query.end()) {
    single_query(req, "unit");
    file.scale = unit_scale(u->second);
    file.unit = u->second;
  } else if (req.query.count("scale")) {
    file.scale = query_number(req, "scale");
    if (!(file.scale > 0) || file.scale > kMaxCoordinate) throw InvalidInput("scale", "scale must be in (0, 1e6] (metres per file unit)");
    file.unit = "";
  }
}

}  // namespace

UploadFile decode_upload(Request& req, const Limits& limits) {
  UploadFile file;
  file.format = upload_format(req);
  // Binary STL states its triangle count up front: refuse before parsing (after the size check,
  // so that garbage is called invalid rather than too large).
  if (file.format == "stl")
    if (const auto n = mesh::binary_stl_triangles(req.body, "body"); n && *n > limits.max_upload_triangles) throw too_many_triangles(limits);
  upload_unit(req, file);
  // A link's upload again (POST .../uploads/reuse answered 404): the mesh must be the one the
  // link names.
  if (req.query.count("digest")) {
    single_query(req, "digest");
    file.expected_digest = valid_digest(req.query.at("digest"), "digest");
  }
  file.bytes = std::move(req.body);
  return file;
}

std::shared_ptr<const Upload> read_upload(const UploadFile& file, const Limits& limits) {
  auto upload = std::make_shared<Upload>();
  upload->format = file.format;
  upload->unit = file.unit;
  upload->scale = file.scale;
  upload->surface = load_bytes(file.bytes, file.format, limits, file.scale);
  upload->bytes = file.bytes.size();
  if (static_cast<std::size_t>(upload->surface.faces.rows()) > limits.max_upload_triangles) throw too_many_triangles(limits);
  upload->digest = kelvin::surface_digest(upload->surface);
  if (!file.expected_digest.empty() && upload->digest != file.expected_digest)
    throw ApiError(422, "different_mesh",
                   "this file's mesh has the digest " + upload->digest + ", not the expected " + file.expected_digest +
                       ": it is another file, or the same file read in another unit",
                   "body");
  return upload;
}

UploadDigest decode_reuse(const Request& req, const Limits& /*limits*/) {
  const json body = parse_body(req);
  json_require_object(body, "");
  json_check_keys(body, "", {"digest", "comment"});
  if (!body.contains("digest") || !body["digest"].is_string()) throw InvalidInput("digest", "digest is required (64 hex digits)");
  return {valid_digest(body["digest"].get<std::string>(), "digest")};
}

UploadId decode_upload_id(const Request& req, const Limits& /*limits*/) { return {req.params.at("id")}; }

Response encode_assets(const AssetNames& assets) { return json_response(200, {{"assets", assets.names}}); }

Response encode_upload(const UploadDescription& added) {
  const Upload& up = *added.upload;
  json answer = {{"upload", added.id}, {"n_vertices", up.surface.vertices.rows()}, {"n_faces", up.surface.faces.rows()}, {"scale", up.scale}, {"digest", up.digest}, {"bytes", up.bytes}, {"format", up.format}};
  if (!up.unit.empty()) answer["unit"] = up.unit;
  const SizeReport& size = added.size;
  answer["bounding_box"] = {{"min", size.min}, {"max", size.max}, {"diagonal", size.diagonal}};
  answer["lx_range"] = nullptr;
  answer["lx_fraction_range"] = nullptr;
  if (size.lx_range) {
    const auto [lo, hi] = *size.lx_range;
    answer["lx_range"] = {{"min", lo}, {"max", hi}};
    answer["lx_fraction_range"] = {{"min", lo / size.diagonal}, {"max", hi / size.diagonal}};
  }
  if (added.reused) answer["reused"] = true;
  return json_response(201, answer);
}

Response encode_upload_surface(const UploadSurface& surface) {
  Response r;
  r.content_type = "application/msgpack";
  r.body = to_msgpack(mesh_frame(surface.upload->surface, {{"type", "surface"}, {"of", "upload"}, {"upload", surface.id}, {"digest", surface.upload->digest}}));
  return r;
}

// Counts, then the lists (at most max_items entries each).
Response encode_upload_defects(const UploadDefects& found) {
  const mesh::MeshDefects& d = found.defects;
  json pieces = json::array();
  for (const auto& p : d.pieces) pieces.push_back({{"faces", p.faces}, {"volume", p.volume}, {"runs", p.runs}});
  const json answer = {{"upload", found.id},
                       {"counts", {{"boundary_edges", d.boundary_edges}, {"non_manifold_edges", d.non_manifold_edges}, {"non_manifold_vertices", d.non_manifold_vertices}, {"degenerate_faces", d.degenerate_faces}, {"self_intersections", d.self_intersections}, {"components", d.pieces.size()}}},
                       {"self_intersections_complete", d.self_intersections_complete},
                       {"unchecked_faces", d.unchecked_faces},
                       {"boundary_edges", d.boundary},
                       {"non_manifold_edges", d.non_manifold},
                       {"non_manifold_vertices", d.pinched},
                       {"degenerate_faces", d.degenerate},
                       {"self_intersections", d.intersecting},
                       {"components", pieces},
                       {"largest_component", d.largest},
                       {"max_items", found.max_items},
                       {"truncated", d.truncated}};
  return json_response(200, answer);
}

}  // namespace distlab::server
