// Static file serving without path traversal.
#include "distlab/server/static_files.hpp"

#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

namespace distlab::server {
namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxStaticBytes = std::size_t{256} << 20;

const char* kFallbackPage = R"(<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>distlab</title></head>
<body><h1>distlab service</h1>
<p>The front end is not built (no index.html in the web directory). The API is documented at
<a href="/api/openapi.json">/api/openapi.json</a>; health: <a href="/api/health">/api/health</a>.</p>
</body></html>
)";

Response not_found() { return error_response(404, "not_found", "no such file"); }

}  // namespace

StaticFiles::StaticFiles(const std::string& root) {
  std::error_code ec;
  const fs::path canonical = fs::canonical(root, ec);
  if (!ec && fs::is_directory(canonical, ec)) root_ = canonical.string();
}

std::string StaticFiles::content_type(const std::string& path) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"}, {".htm", "text/html; charset=utf-8"}, {".js", "text/javascript; charset=utf-8"}, {".mjs", "text/javascript; charset=utf-8"}, {".css", "text/css; charset=utf-8"}, {".json", "application/json"}, {".map", "application/json"}, {".svg", "image/svg+xml"}, {".png", "image/png"}, {".jpg", "image/jpeg"}, {".jpeg", "image/jpeg"}, {".gif", "image/gif"}, {".ico", "image/x-icon"}, {".webp", "image/webp"}, {".wasm", "application/wasm"}, {".txt", "text/plain; charset=utf-8"}, {".woff", "font/woff"}, {".woff2", "font/woff2"}, {".glb", "model/gltf-binary"}, {".gltf", "model/gltf+json"}, {".stl", "model/stl"}, {".obj", "model/obj"}, {".ply", "application/octet-stream"}, {".glsl", "text/plain; charset=utf-8"}};
  const std::string ext = fs::path(path).extension().string();
  auto it = types.find(ext);
  return it == types.end() ? "application/octet-stream" : it->second;
}

Response StaticFiles::serve(const Request& request) const {
  if (request.method != "GET" && request.method != "HEAD") {
    Response r = error_response(405, "method_not_allowed", "static files are read-only");
    r.headers.emplace_back("Allow", "GET, HEAD");
    return r;
  }
  std::string decoded;
  if (!percent_decode(request.path, decoded)) return not_found();
  if (decoded.empty() || decoded.front() != '/' || decoded.find('\\') != std::string::npos) return not_found();
  // Refuse any "." or ".." segment outright (after decoding: %2e%2e is caught here).
  std::stringstream ss(decoded.substr(1));
  std::string seg;
  fs::path rel;
  while (std::getline(ss, seg, '/')) {
    if (seg == "." || seg == "..") return not_found();
    if (!seg.empty()) rel /= seg;
  }
  if (root_.empty()) {
    if (rel.empty()) {
      Response r;
      r.content_type = "text/html; charset=utf-8";
      r.body = kFallbackPage;
      return r;
    }
    return not_found();
  }
  const fs::path root(root_);
  fs::path file = root / rel;
  std::error_code ec;
  if (fs::is_directory(file, ec)) file /= "index.html";
  const fs::path canonical = fs::canonical(file, ec);
  if (ec || !fs::is_regular_file(canonical, ec)) {
    if (rel.empty()) {  // no index.html: the built-in page
      Response r;
      r.content_type = "text/html; charset=utf-8";
      r.body = kFallbackPage;
      return r;
    }
    return not_found();
  }
  // Symlinks must not lead out of the root either.
  const std::string c = canonical.string();
  if (c.size() <= root_.size() || c.compare(0, root_.size(), root_) != 0 || c[root_.size()] != '/')
    return not_found();
  const auto size = fs::file_size(canonical, ec);
  if (ec || size > kMaxStaticBytes) return not_found();
  std::ifstream in(canonical, std::ios::binary);
  if (!in) return not_found();
  Response r;
  r.content_type = content_type(c);
  r.body.resize(static_cast<std::size_t>(size));
  in.read(r.body.data(), static_cast<std::streamsize>(size));
  r.body.resize(static_cast<std::size_t>(in.gcount()));
  r.headers.emplace_back("Cache-Control", "no-cache");
  return r;
}

}  // namespace distlab::server
