#pragma once
// The codec of the Kelvin upload routes (routes_kelvin_uploads.cpp): decode reads a request into
// a typed input and is the one place that checks it; encode writes a handler's typed result as
// the answer (route_table.hpp).
#include <array>
#include <cstddef>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "distlab/mesh/checks.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/uploads.hpp"

namespace distlab::server {

// GET /api/kelvin/assets: the built-in meshes' names, sorted.
struct AssetNames {
  std::vector<std::string> names;
};

// POST /api/kelvin/uploads/reuse: the digest of a mesh some session uploaded.
struct UploadDigest {
  std::string digest;
};

// {id} of /api/kelvin/uploads/{id}/...
struct UploadId {
  std::string id;
};

// What a client needs to choose l_x for a surface: its welded bounding box, and the l_x range
// [max(min_lx, smallest_lx_within), half the largest extent] at the default far radius, none when
// no l_x fits.
struct SizeReport {
  std::array<double, 3> min{}, max{};
  double diagonal = 0;
  std::optional<std::array<double, 2>> lx_range;
};

// An upload added to a session (POST .../uploads, .../uploads/reuse).
struct UploadDescription {
  std::string id;
  std::shared_ptr<const Upload> upload;
  SizeReport size;
  bool reused = false;  // given by its digest (.../reuse)
};

// GET .../uploads/{id}/surface.
struct UploadSurface {
  std::string id;
  std::shared_ptr<const Upload> upload;
};

// GET .../uploads/{id}/defects: at most max_items entries per list.
struct UploadDefects {
  std::string id;
  mesh::MeshDefects defects;
  std::size_t max_items = 0;
};

// POST /api/kelvin/uploads before its parse: the query (format; unit or scale; the digest a link
// expects) and the file's bytes, moved out of the request.
struct UploadFile {
  std::string bytes, format, unit;  // unit "" when a scale was given
  double scale = 1.0;               // metres per file unit
  std::string expected_digest;      // "" when the link named none
};

// Checks what needs no parse: the query, an empty body, a binary STL's stated triangle count.
UploadFile decode_upload(Request& req, const Limits& limits);
// The file parsed in the isolated child (load_bytes) and checked: its triangle count, and the digest
// a link expects (422 different_mesh). The handler calls it once the caller may upload (its session,
// room for one more), so that a refused caller costs no parse.
std::shared_ptr<const Upload> read_upload(const UploadFile& file, const Limits& limits);
UploadDigest decode_reuse(const Request& req, const Limits& limits);
UploadId decode_upload_id(const Request& req, const Limits& limits);

Response encode_assets(const AssetNames& assets);
Response encode_upload(const UploadDescription& added);        // 201
Response encode_upload_surface(const UploadSurface& surface);  // msgpack mesh frame
Response encode_upload_defects(const UploadDefects& found);

}  // namespace distlab::server
