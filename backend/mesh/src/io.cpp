// Mesh import in the file's own vertex order (CGAL's polygon-soup readers; stl.cpp; assimp for glTF), and
// export through assimp. Counts declared in headers are checked against the file's size before a
// reader allocates anything, and every index and coordinate is checked before it is used.
#include <CGAL/IO/OBJ.h>
#include <CGAL/IO/OFF.h>
#include <CGAL/IO/PLY.h>
#include <CGAL/Simple_cartesian.h>
#include <assimp/DefaultIOSystem.h>
#include <assimp/config.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"
#include "number_word.hpp"
#include "polygons.hpp"
#include "stl.hpp"

namespace distlab::mesh {

namespace {

using detail::Point;
using Soup = std::vector<std::vector<std::size_t>>;

std::string read_all(const std::string& path) {
  std::ifstream in(path, std::ios::binary | std::ios::ate);
  std::string bytes(static_cast<std::size_t>(std::max<std::streamoff>(in.tellg(), 0)), '\0');
  in.seekg(0);
  in.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  bytes.resize(static_cast<std::size_t>(in.gcount()));
  return bytes;
}

// A declared count that the file's bytes cannot hold is refused before any reader sizes a buffer
// by it (a 34-byte OFF declaring 1e9 vertices must not allocate 24 GB).
void require_room(const std::string& what, std::uint64_t need, std::uint64_t have, const std::string& field) {
  if (need > have)
    throw InvalidInput(field, "the file declares " + what + ", which needs at least " + std::to_string(need) +
                                  " bytes, but it has only " + std::to_string(have));
}

// Parses a decimal count; refuses anything that is not one, or does not fit an int index.
std::uint64_t count(const std::string& token, const std::string& what, const std::string& field) {
  if (token.empty() || token.size() > 19 || !std::all_of(token.begin(), token.end(), [](char c) { return c >= '0' && c <= '9'; }))
    throw InvalidInput(field, "the " + what + " count '" + token.substr(0, 20) + "' is not a non-negative integer");
  const std::uint64_t n = std::stoull(token);
  if (n > static_cast<std::uint64_t>(std::numeric_limits<int>::max()))
    throw InvalidInput(field, "the file declares " + token + " " + (what == "vertex" ? std::string("vertices") : what + "s") + " (at most " +
                                  std::to_string(std::numeric_limits<int>::max()) + ")");
  return n;
}

bool is_index(std::string_view t) {
  return !t.empty() && t.size() <= 10 && std::all_of(t.begin(), t.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  for (std::size_t at = 0; (at = line.find_first_not_of(" \t\r\f\v", at)) != std::string_view::npos;) {
    const std::size_t end = std::min(line.find_first_of(" \t\r\f\v", at), line.size());
    out.push_back(line.substr(at, end - at));
    at = end;
  }
  return out;
}

// OFF: "[ST][C][N][4]OFF" then "nv nf ne". An ASCII vertex takes at least 6 bytes ("0 0 0\n"), a
// triangle at least 8 ("3 0 1 2\n"). Then the body is walked the way CGAL's scanner reads it (one
// vertex or face per line, '#' comments): CGAL sizes a face by its declared vertex count and
// casts it from a double, so every face line must hold the count it declares, all of them
// integer indices below nv.
void check_off(const std::string& bytes, const std::string& field) {
  std::istringstream in(bytes);
  std::string token;
  auto next = [&]() {
    while (in >> token) {
      if (token[0] != '#') return true;
      std::getline(in, token);
    }
    return false;
  };
  if (!next() || token.size() < 3 || token.substr(token.size() - 3) != "OFF" ||
      token.find_first_not_of("STCN4") < token.size() - 3)
    throw InvalidInput(field, "not an OFF file: it must start with OFF (or COFF, NOFF, STOFF, 4OFF)");
  std::array<std::string, 3> counts;
  for (auto& c : counts)
    if (!next()) throw InvalidInput(field, "the OFF header must give the numbers of vertices, faces and edges");
    else c = token;
  if (counts[0] == "BINARY") throw InvalidInput(field, "binary OFF is not supported; use ASCII OFF, PLY or STL");
  const std::uint64_t nv = count(counts[0], "vertex", field), nf = count(counts[1], "face", field);
  count(counts[2], "edge", field);
  std::size_t at = in.eof() ? bytes.size() : static_cast<std::size_t>(in.tellg());
  require_room(std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces", nv * 6 + nf * 8,
               bytes.size() - at + 1, field);

  const std::string_view body(bytes);
  at = std::min(body.find('\n', at), body.size() - 1) + 1;  // past the rest of the counts' line
  auto next_line = [&]() -> std::optional<std::vector<std::string_view>> {
    while (at < body.size()) {
      const std::size_t end = std::min(body.find('\n', at), body.size());
      std::string_view line = body.substr(at, end - at);
      at = end + 1;
      line = line.substr(0, line.find('#'));
      if (auto w = words(line); !w.empty()) return w;
    }
    return std::nullopt;
  };
  for (std::uint64_t v = 0; v < nv; ++v)
    if (!next_line()) throw InvalidInput(field, "the OFF file ends before its " + std::to_string(nv) + " vertices");
  for (std::uint64_t f = 0; f < nf; ++f) {
    const auto w = next_line();
    if (!w) throw InvalidInput(field, "the OFF file ends before its " + std::to_string(nf) + " faces");
    const std::string face = "face " + std::to_string(f);
    if (!is_index((*w)[0])) throw InvalidInput(field, face + ": its vertex count is not a non-negative integer");
    const std::uint64_t k = std::stoull(std::string((*w)[0]));
    if (k + 1 > w->size())
      throw InvalidInput(field, face + " declares " + std::to_string(k) + " vertices but lists " + std::to_string(w->size() - 1));
    for (std::size_t j = 1; j <= k; ++j)
      if (!is_index((*w)[j]) || std::stoull(std::string((*w)[j])) >= nv)
        throw InvalidInput(field, face + " has a vertex index out of range (the file has " + std::to_string(nv) + " vertices)");
  }
}

// OBJ text as CGAL's reader takes it: UTF-16 (a byte-order mark) is transcoded when every
// character is ASCII, as OBJ keywords and numbers are; point ("p") and line ("l") records, which
// CGAL's reader refuses, are dropped; a file without any face ("f") is a point cloud or a set of
// lines, refused as such.
std::string obj_text(std::string bytes, const std::string& field) {
  const bool le = bytes.rfind("\xFF\xFE", 0) == 0, be = bytes.rfind("\xFE\xFF", 0) == 0;
  if (le || be) {
    if (bytes.size() % 2 != 0) throw InvalidInput(field, "this UTF-16 OBJ file has an odd number of bytes: it is truncated");
    std::string ascii;
    ascii.reserve(bytes.size() / 2);
    for (std::size_t at = 2; at + 1 < bytes.size(); at += 2) {
      const auto hi = static_cast<unsigned char>(bytes[at + (le ? 1 : 0)]), lo = static_cast<unsigned char>(bytes[at + (le ? 0 : 1)]);
      if (hi != 0 || lo >= 0x80)
        throw InvalidInput(field, "this UTF-16 OBJ file has a non-ASCII character at byte " + std::to_string(at) +
                                      "; save it as ASCII or UTF-8");
      ascii.push_back(static_cast<char>(lo));
    }
    bytes = std::move(ascii);
  } else if (bytes.size() >= 2 && (bytes[0] == '\0' || bytes[1] == '\0')) {
    throw InvalidInput(field, "this OBJ file looks like UTF-16 without a byte-order mark; save it as ASCII or UTF-8");
  }
  std::string out;
  out.reserve(bytes.size());
  std::size_t vertices = 0, faces = 0, dropped = 0, line_number = 0;
  for (std::size_t at = 0; at < bytes.size();) {
    const std::size_t end = std::min(bytes.find('\n', at), bytes.size());
    const std::string_view line = std::string_view(bytes).substr(at, end - at);
    const auto w = words(line);
    const std::string_view key = w.empty() ? std::string_view() : w[0];
    ++line_number;
    if (key == "v") {
      // CGAL's reader stops at a coordinate it cannot read ("nan") without saying where.
      for (std::size_t k = 1; k <= 3; ++k) {
        const std::string_view word = k < w.size() ? w[k] : std::string_view();
        const std::optional<double> x = detail::number_word(word);
        if (!x || !std::isfinite(*x))
          throw InvalidInput(field, "line " + std::to_string(line_number) + ": vertex " + std::to_string(vertices) +
                                        " (counted from 0) needs three finite coordinates, " +
                                        (word.empty() ? std::string("has fewer") : "has \"" + std::string(word.substr(0, 32)) + "\""));
      }
      ++vertices;
    }
    if (key == "f") ++faces;
    if (key == "p" || key == "l") ++dropped;
    else out.append(line).push_back('\n');
    at = end + 1;
  }
  if (faces == 0)
    throw InvalidInput(field, "the OBJ file has " + std::to_string(vertices) + " vertices" +
                                  (dropped ? " and " + std::to_string(dropped) + " point or line records" : std::string()) +
                                  " but no faces: a point cloud or a set of lines is not a surface");
  return out;
}

// PLY: every element's count times its smallest record (ASCII: 2 bytes per scalar or list count,
// binary: the scalar sizes and the list count's size) must fit in the body. Then the body is
// walked record by record: every list must fit in what is left of the file before CGAL's reader
// sizes a buffer by its count (a binary uint count can say 4294967295).
// A binary glTF: a 12-byte header (magic, version 2, total length) and chunks (length, type, data);
// every length must fit in the file before assimp sizes a buffer from it.
void check_glb(const std::string& bytes, const std::string& field) {
  if (bytes.rfind("glTF", 0) != 0) return;  // a text .gltf (JSON), or not glTF: assimp says which
  auto u32 = [&](std::size_t at) {
    std::uint32_t v = 0;
    std::memcpy(&v, bytes.data() + at, 4);  // little-endian, as the format and every target are
    return v;
  };
  require_room("a GLB header", 12, bytes.size(), field);
  if (u32(4) != 2)
    throw InvalidInput(field, "this GLB is glTF version " + std::to_string(u32(4)) + "; only glTF 2.0 binaries are supported");
  require_room("a GLB of " + std::to_string(u32(8)) + " bytes", u32(8), bytes.size(), field);
  for (std::size_t at = 12; at + 8 <= bytes.size();) {
    const std::uint64_t length = u32(at);
    require_room("a GLB chunk of " + std::to_string(length) + " bytes", at + 8 + length, bytes.size(), field);
    at += 8 + length;
  }
}

void check_ply(const std::string& bytes, const std::string& field) {
  // The header as CGAL's reader walks it: whole lines, keyed by their first word, up to the first
  // line whose first word is end_header; any other keyword is refused (CGAL would misread it).
  if (bytes.rfind("ply", 0) != 0) throw InvalidInput(field, "not a PLY file: it must start with \"ply\"");
  std::size_t end = std::string::npos, newline = std::string::npos, line_number = 1;
  for (std::size_t at = 0; at < bytes.size();) {
    const std::size_t stop = std::min(bytes.find('\n', at), bytes.size());
    std::istringstream w(bytes.substr(at, stop - at));
    std::string key;
    w >> key;
    if (key == "end_header") {
      end = at;
      newline = stop == bytes.size() ? std::string::npos : stop;
      break;
    }
    if (key != "ply" && key != "format" && key != "comment" && key != "obj_info" && key != "element" && key != "property")
      throw InvalidInput(field, "not a valid PLY header: line " + std::to_string(line_number) +
                                    " is not a PLY header line (ply, format, comment, obj_info, element, property, end_header)");
    at = stop + 1;
    ++line_number;
  }
  if (end == std::string::npos) throw InvalidInput(field, "not a PLY file: its header has no end_header line");
  std::istringstream in(bytes.substr(0, end));
  static const std::map<std::string, std::uint64_t> sizes = {
      {"char", 1}, {"uchar", 1}, {"int8", 1}, {"uint8", 1}, {"short", 2}, {"ushort", 2}, {"int16", 2}, {"uint16", 2}, {"int", 4}, {"uint", 4}, {"int32", 4}, {"uint32", 4}, {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
  struct Property {
    std::uint64_t count_size = 0, size = 0;
  };  // count_size 0: a scalar
  struct Element {
    std::string name;
    std::uint64_t items = 0;
    std::vector<Property> properties;
  };
  std::vector<Element> elements;
  bool ascii = true, big_endian = false;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream w(line);
    std::string key;
    w >> key;
    if (key == "format") {
      std::string f;
      w >> f;
      if (f != "ascii" && f != "binary_little_endian" && f != "binary_big_endian")
        throw InvalidInput(field, "unknown PLY format '" + f.substr(0, 32) + "'");
      ascii = f == "ascii";
      big_endian = f == "binary_big_endian";
    } else if (key == "element") {
      std::string n;
      elements.emplace_back();
      w >> elements.back().name >> n;
      elements.back().name = elements.back().name.substr(0, 32);
      elements.back().items = count(n, "PLY '" + elements.back().name + "' element", field);
    } else if (key == "property") {
      if (elements.empty()) throw InvalidInput(field, "a PLY property comes before any element");
      std::string type, counted, item;
      w >> type;
      if (type == "list") w >> counted >> item;
      else item = counted = type;
      const auto count_size = sizes.find(counted), item_size = sizes.find(item);
      if (count_size == sizes.end() || item_size == sizes.end())
        throw InvalidInput(field, "unknown PLY property type in '" + line.substr(0, 64) + "'");
      // CGAL reads a vertex's x, y and z as float or double only (another type is a null pointer
      // inside its reader).
      std::string name;
      w >> name;
      const bool real = item == "float" || item == "float32" || item == "double" || item == "float64";
      if (elements.back().name == "vertex" && (name == "x" || name == "y" || name == "z") && (type == "list" || !real))
        throw InvalidInput(field, "the PLY vertex property '" + name + "' must be a float or double, not '" + line.substr(0, 64) + "'");
      elements.back().properties.push_back({type == "list" ? count_size->second : 0, item_size->second});
    }
  }
  const std::uint64_t have = newline == std::string::npos ? 0 : bytes.size() - newline - 1;
  std::uint64_t need = 0;
  for (const Element& e : elements) {
    std::uint64_t record = 0;
    for (const Property& p : e.properties) record += ascii ? 2 : (p.count_size ? p.count_size : p.size);
    if (e.items > 0 && record > (std::uint64_t{1} << 40) / e.items)
      throw InvalidInput(field, "the PLY element '" + e.name + "' is too large for the file");
    need += e.items * record;
  }
  require_room("its PLY elements", ascii && need > 0 ? need - 1 : need, have, field);

  std::size_t at = newline == std::string::npos ? bytes.size() : newline + 1;
  const std::string_view body(bytes);
  auto token = [&]() -> std::string_view {
    at = std::min(body.find_first_not_of(" \t\r\n\f\v", at), body.size());
    const std::size_t stop = std::min(body.find_first_of(" \t\r\n\f\v", at), body.size());
    const std::string_view t = body.substr(at, stop - at);
    at = stop;
    return t;
  };
  auto binary_count = [&](std::uint64_t size) {
    std::uint64_t n = 0;
    for (std::uint64_t b = 0; b < size; ++b) {
      const auto byte = static_cast<unsigned char>(body[at + (big_endian ? b : size - 1 - b)]);
      n = (n << 8) | byte;
    }
    at += size;
    return n;
  };
  const auto truncated = [&](const Element& e) {
    return InvalidInput(field, "the PLY file ends inside its '" + e.name + "' elements");
  };
  for (const Element& e : elements)
    for (std::uint64_t i = 0; i < e.items; ++i)
      for (const Property& p : e.properties) {
        if (ascii) {
          const std::string_view t = token();
          if (t.empty()) throw truncated(e);
          if (p.count_size == 0) continue;
          if (!is_index(t)) throw InvalidInput(field, "a PLY list length '" + std::string(t.substr(0, 12)) + "' is not a count");
          const std::uint64_t n = std::stoull(std::string(t));
          if (n > (body.size() - at) / 2 + 1)
            throw InvalidInput(field, "a PLY '" + e.name + "' list of " + std::to_string(n) + " values does not fit in the file");
          for (std::uint64_t k = 0; k < n; ++k)
            if (token().empty()) throw truncated(e);
        } else {
          const std::uint64_t size = p.count_size ? p.count_size : p.size;
          if (body.size() - at < size) throw truncated(e);
          if (p.count_size == 0) {
            at += size;
            continue;
          }
          const std::uint64_t n = binary_count(size);
          if (n > (body.size() - at) / p.size)
            throw InvalidInput(field, "a PLY '" + e.name + "' list of " + std::to_string(n) + " values does not fit in the file");
          at += n * p.size;
        }
      }
}

// Opens the one file being imported and nothing else: a glTF buffer's "uri" must not make the
// server read its own files into a mesh.
class OnlyThisFile : public Assimp::DefaultIOSystem {
 public:
  explicit OnlyThisFile(std::string path) : path_(std::move(path)) {}
  using DefaultIOSystem::Exists;
  using DefaultIOSystem::Open;
  bool Exists(const char* file) const override { return path_ == file && DefaultIOSystem::Exists(file); }
  Assimp::IOStream* Open(const char* file, const char* mode) override {
    return path_ == file && std::strchr(mode, 'w') == nullptr ? DefaultIOSystem::Open(file, mode) : nullptr;
  }

 private:
  std::string path_;
};

// The triangles each glTF primitive declares (its indices' count / 3, or its positions' without
// indices), in the order in which assimp makes one aiMesh per primitive; nullopt where the mode
// is not triangles. assimp drops a triangle with an out-of-range index and only logs it: this
// count is how such a file is refused instead of silently losing faces. Empty if unreadable.
std::vector<std::optional<std::size_t>> gltf_declared_triangles(const std::string& bytes) {
  std::string_view text = bytes;
  if (bytes.size() >= 20 && bytes.compare(0, 4, "glTF") == 0) {  // GLB: header, then the JSON chunk
    std::uint32_t length = 0, type = 0;
    std::memcpy(&length, bytes.data() + 12, 4);
    std::memcpy(&type, bytes.data() + 16, 4);
    if (type != 0x4E4F534Au || length > bytes.size() - 20) return {};
    text = std::string_view(bytes).substr(20, length);
  }
  const nlohmann::json doc = nlohmann::json::parse(text, nullptr, false);
  std::vector<std::optional<std::size_t>> out;
  if (!doc.is_object() || !doc.contains("meshes") || !doc["meshes"].is_array() || !doc.contains("accessors")) return out;
  const nlohmann::json& accessors = doc["accessors"];
  auto count = [&](const nlohmann::json& index) -> std::optional<std::size_t> {
    if (!index.is_number_unsigned() || !accessors.is_array() || index.get<std::size_t>() >= accessors.size()) return std::nullopt;
    const nlohmann::json& a = accessors[index.get<std::size_t>()];
    if (!a.is_object() || !a.contains("count") || !a["count"].is_number_unsigned()) return std::nullopt;
    return a["count"].get<std::size_t>();
  };
  for (const nlohmann::json& mesh : doc["meshes"]) {
    if (!mesh.is_object() || !mesh.contains("primitives") || !mesh["primitives"].is_array()) return {};
    for (const nlohmann::json& p : mesh["primitives"]) {
      if (!p.is_object()) return {};
      const bool triangles = !p.contains("mode") || p["mode"] == 4;
      std::optional<std::size_t> n;
      if (p.contains("indices")) n = count(p["indices"]);
      else if (p.contains("attributes") && p["attributes"].is_object() && p["attributes"].contains("POSITION"))
        n = count(p["attributes"]["POSITION"]);
      out.push_back(triangles && n ? std::optional<std::size_t>(*n / 3) : std::nullopt);
    }
  }
  return out;
}

// glTF/GLB and Collada (format "dae") through assimp (no post-processing that moves vertices):
// each mesh's vertices in its accessor's order, meshes in the order the node tree (depth first)
// places them, with the nodes' transforms applied. Collada: its <unit meter> scale is applied and
// its up_axis is not (URDF's convention: coordinates as the file writes them, in its unit).
void read_assimp(const std::string& path, const std::string& format, std::vector<Point>& points, Soup& soup,
                 const std::string& field) {
  Assimp::Importer importer;
  importer.SetIOHandler(new OnlyThisFile(path));  // owned by the importer
  importer.SetPropertyBool(AI_CONFIG_IMPORT_COLLADA_IGNORE_UP_DIRECTION, true);
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  // A path without its format's extension (an upload's anonymous file) is read from memory with
  // the format as assimp's hint (glTF: a self-contained GLB).
  const bool named = format == "dae" ? ext == ".dae" : ext == ".glb" || ext == ".gltf";
  const std::string bytes = named ? std::string() : read_all(path);
  const char* hint = format == "dae" ? "dae" : "glb";
  const aiScene* scene = bytes.empty() ? importer.ReadFile(path, aiProcess_ValidateDataStructure)
                                       : importer.ReadFileFromMemory(bytes.data(), bytes.size(), aiProcess_ValidateDataStructure, hint);
  if (scene == nullptr || scene->mRootNode == nullptr) {
    // assimp's message may quote the path (a server temp name): say "the file" instead.
    std::string why = importer.GetErrorString();
    for (const std::string& name : {path, std::filesystem::path(path).filename().string()})
      for (std::size_t at; !name.empty() && (at = why.find(name)) != std::string::npos;) why.replace(at, name.size(), "the file");
    throw InvalidInput(field, std::string("cannot read the ") + (format == "dae" ? "Collada" : "glTF") + " file: " + why);
  }
  // Totals, not primitive by primitive: assimp does not keep the file's primitive order.
  const auto declared = format == "dae" ? std::vector<std::optional<std::size_t>>{}
                                        : gltf_declared_triangles(bytes.empty() ? read_all(path) : bytes);
  if (declared.size() == scene->mNumMeshes && std::all_of(declared.begin(), declared.end(), [](auto& d) { return d.has_value(); })) {
    std::size_t want = 0, got = 0;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) want += *declared[m], got += scene->mMeshes[m]->mNumFaces;
    if (got < want)
      throw InvalidInput(field, "the glTF file declares " + std::to_string(want) + " triangles, of which " +
                                    std::to_string(want - got) + " index a vertex out of range");
  }
  std::vector<std::pair<const aiNode*, aiMatrix4x4>> stack{{scene->mRootNode, scene->mRootNode->mTransformation}};
  while (!stack.empty()) {
    auto [node, transform] = stack.back();
    stack.pop_back();
    for (unsigned i = 0; i < node->mNumMeshes; ++i) {
      const aiMesh* mesh = scene->mMeshes[node->mMeshes[i]];  // validated by assimp
      const std::size_t base = points.size();
      for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
        const aiVector3D p = transform * mesh->mVertices[v];
        points.emplace_back(p.x, p.y, p.z);
      }
      for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
        const aiFace& face = mesh->mFaces[f];
        if (face.mNumIndices < 3) continue;  // points and lines
        soup.emplace_back();
        for (unsigned k = 0; k < face.mNumIndices; ++k) soup.back().push_back(base + face.mIndices[k]);
      }
    }
    // Children pushed in reverse so that they are visited in order.
    for (unsigned c = node->mNumChildren; c-- > 0;)
      stack.emplace_back(node->mChildren[c], transform * node->mChildren[c]->mTransformation);
  }
}

}  // namespace

SurfaceMesh load_mesh(const std::string& path, const std::string& field, const std::string& format_in) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec))
    throw InvalidInput(field, "cannot read the mesh file: no such file");
  std::string ext = format_in.empty() ? std::filesystem::path(path).extension().string() : "." + format_in;
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (std::filesystem::file_size(path, ec) == 0 && !ec) throw InvalidInput(field, "the file is empty");

  std::vector<Point> points;
  Soup soup;
  bool ok = true;
  try {
    const auto quiet = CGAL::parameters::verbose(false);
    if (ext == ".stl") {
      detail::read_stl(read_all(path), points, soup, field);
    } else if (ext == ".off") {
      check_off(read_all(path), field);
      ok = CGAL::IO::read_OFF(path, points, soup, quiet);
    } else if (ext == ".ply") {
      check_ply(read_all(path), field);
      ok = CGAL::IO::read_PLY(path, points, soup, quiet);
    } else if (ext == ".obj") {
      std::istringstream text(obj_text(read_all(path), field));
      ok = CGAL::IO::read_OBJ(text, points, soup, quiet);
    } else if (ext == ".gltf" || ext == ".glb") {
      if (ext == ".glb") check_glb(read_all(path), field);
      read_assimp(path, "glb", points, soup, field);
    } else if (ext == ".dae") {
      read_assimp(path, "dae", points, soup, field);
    } else {
      throw InvalidInput(field, "unsupported mesh format '" + ext + "' (use stl, obj, ply, off, gltf, glb or dae)");
    }
  } catch (const CGAL::Failure_exception&) {
    ok = false;  // a CGAL precondition on malformed input (debug builds)
  }
  const std::string format = ext.substr(std::min<std::size_t>(1, ext.size()));
  if (!ok)  // CGAL's OBJ reader refuses out-of-range indices itself, with the same answer
    throw InvalidInput(field, "cannot read the " + format + " file: it is malformed or truncated" +
                                  (format == "obj" ? ", or a face index is out of range" : ""));

  // Faces index the file's vertices; polygons become triangles of the same vertices.
  const std::size_t nv = points.size();
  if (nv > static_cast<std::size_t>(std::numeric_limits<int>::max()))
    throw InvalidInput(field, "the file has too many vertices");
  for (std::size_t f = 0; f < soup.size(); ++f) {
    if (soup[f].size() < 3) throw InvalidInput(field, "face " + std::to_string(f) + " has fewer than 3 vertices");
    for (const std::size_t i : soup[f])
      if (i >= nv)
        throw InvalidInput(field, "face " + std::to_string(f) + " has a vertex index out of range (the file has " +
                                      std::to_string(nv) + " vertices)");
  }
  if (soup.empty())
    throw InvalidInput(field, "the file has " + std::to_string(nv) + " vertices but no faces: a point cloud is not a surface");
  SurfaceMesh out;
  out.vertices.resize(static_cast<Eigen::Index>(nv), 3);
  for (std::size_t v = 0; v < nv; ++v) {
    const Point& p = points[v];
    if (!std::isfinite(p.x()) || !std::isfinite(p.y()) || !std::isfinite(p.z()))
      throw InvalidInput(field, "vertex " + std::to_string(v) + " has a non-finite coordinate (NaN or infinity)");
    out.vertices.row(static_cast<Eigen::Index>(v)) << p.x(), p.y(), p.z();
  }
  std::vector<detail::Triangle> triangles;
  triangles.reserve(soup.size());
  bool polygons = false;
  for (std::size_t f = 0; f < soup.size(); ++f) {
    if (soup[f].size() == 3) {
      triangles.push_back({soup[f][0], soup[f][1], soup[f][2]});
      continue;
    }
    const std::vector<detail::Triangle> split = detail::triangulate_polygon(points, soup[f], f, field);
    triangles.insert(triangles.end(), split.begin(), split.end());
    polygons = polygons || split.size() != 1;
  }
  if (triangles.empty()) throw InvalidInput(field, "the mesh file contains no triangles");
  out.faces.resize(static_cast<Eigen::Index>(triangles.size()), 3);
  for (std::size_t t = 0; t < triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) out.faces(static_cast<Eigen::Index>(t), k) = static_cast<int>(triangles[t][static_cast<std::size_t>(k)]);
  // The corner counts, so that what is said about a triangle names the user's face.
  if (polygons)
    for (const auto& polygon : soup) out.polygon_corners.push_back(static_cast<int>(polygon.size()));
  return out;
}

std::string file_face_name(const SurfaceMesh& mesh, Eigen::Index triangle) {
  const std::vector<int>& corners = mesh.polygon_corners;
  Eigen::Index first = 0;  // T(f) = Σ_{g<f} (k_g − 2)
  for (std::size_t f = 0; f < corners.size() && corners[f] >= 3; ++f) {
    const int fan = corners[f] - 2;
    if (triangle < first + fan) {
      // Only when the counts cover exactly the faces: anything else is not the file's numbering.
      Eigen::Index total = 0;
      for (const int k : corners) total += k - 2;
      if (total != mesh.faces.rows()) break;
      if (fan == 1) return "face " + std::to_string(f);
      return "face " + std::to_string(f) + " (triangle " + std::to_string(triangle - first) + " of its " +
             std::to_string(corners[f]) + "-corner polygon)";
    }
    first += fan;
  }
  return "face " + std::to_string(triangle);
}

void save_mesh(const SurfaceMesh& mesh, const std::string& path, const std::string& format,
               const std::string& field) {
  // OBJ without a material file: the mesh has no material, and a download is one file.
  static const std::map<std::string, std::string> ids = {
      {"stl", "stlb"}, {"obj", "objnomtl"}, {"ply", "plyb"}, {"glb", "glb2"}};
  auto id = ids.find(format);
  if (id == ids.end())
    throw InvalidInput(field, "unknown mesh format '" + format + "' (use stl, obj, ply or glb)");

  // aiScene's destructor frees everything below, so build it with new[] as assimp expects.
  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode();
  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial* [1] { new aiMaterial() };
  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh* [1] { new aiMesh() };
  scene->mRootNode->mNumMeshes = 1;
  scene->mRootNode->mMeshes = new unsigned[1]{0};
  aiMesh* out = scene->mMeshes[0];
  out->mMaterialIndex = 0;
  out->mPrimitiveTypes = aiPrimitiveType_TRIANGLE;
  out->mNumVertices = static_cast<unsigned>(mesh.vertices.rows());
  out->mVertices = new aiVector3D[out->mNumVertices];
  for (unsigned v = 0; v < out->mNumVertices; ++v)
    out->mVertices[v] = aiVector3D(static_cast<float>(mesh.vertices(v, 0)),
                                   static_cast<float>(mesh.vertices(v, 1)),
                                   static_cast<float>(mesh.vertices(v, 2)));
  out->mNumFaces = static_cast<unsigned>(mesh.faces.rows());
  out->mFaces = new aiFace[out->mNumFaces];
  for (unsigned f = 0; f < out->mNumFaces; ++f) {
    out->mFaces[f].mNumIndices = 3;
    out->mFaces[f].mIndices = new unsigned[3];
    for (int k = 0; k < 3; ++k)
      out->mFaces[f].mIndices[k] = static_cast<unsigned>(mesh.faces(f, k));
  }
  Assimp::Exporter exporter;
  if (exporter.Export(scene.get(), id->second, path) != aiReturn_SUCCESS)
    throw InvalidInput("path", "cannot write mesh '" + path + "': " + exporter.GetErrorString());
}

double signed_volume(const SurfaceMesh& mesh) {
  double six_v = 0;
  for (Eigen::Index f = 0; f < mesh.faces.rows(); ++f) {
    const Vec3 a = mesh.vertices.row(mesh.faces(f, 0));
    const Vec3 b = mesh.vertices.row(mesh.faces(f, 1));
    const Vec3 c = mesh.vertices.row(mesh.faces(f, 2));
    six_v += a.dot(b.cross(c));
  }
  return six_v / 6.0;
}

}  // namespace distlab::mesh
