// assimp import/export of indexed triangle meshes.
#include <assimp/Exporter.hpp>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
#include <cctype>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"

namespace distlab::mesh {

namespace {

// The STL check from the first bytes of a file (head: at least its first 1024 bytes, or all of
// it) and its size: only the header, the count and the text test are needed.
std::optional<std::uint32_t> stl_triangles(std::string_view head, std::uint64_t size, const std::string& field) {
  std::uint32_t n = 0;
  if (size >= 84 && head.size() >= 84) {
    std::memcpy(&n, head.data() + 80, 4);  // little-endian, as the format and every target are
    if (size == 84 + 50 * static_cast<std::uint64_t>(n)) return n;  // some binary headers start with "solid"
  }
  head = head.substr(0, 1024);
  const bool text = head.find_first_not_of(" \t\r\n") != std::string_view::npos &&
                    head.substr(head.find_first_not_of(" \t\r\n")).rfind("solid", 0) == 0 &&
                    std::none_of(head.begin(), head.end(), [](char c) {
                      const auto u = static_cast<unsigned char>(c);
                      return u < 0x20 && c != '\t' && c != '\r' && c != '\n';
                    });
  if (text) return std::nullopt;
  std::string why = "not a valid STL file: an ASCII STL starts with \"solid\", and a binary STL is exactly 84 + 50·n bytes (n triangles)";
  if (size < 84)
    why += ", but the file has only " + std::to_string(size) + " bytes";
  else
    why += "; its header says n = " + std::to_string(n) + ", i.e. " + std::to_string(84 + 50 * static_cast<std::uint64_t>(n)) +
           " bytes, but the file has " + std::to_string(size) + " bytes";
  throw InvalidInput(field, why);
}

}  // namespace

std::optional<std::uint32_t> binary_stl_triangles(std::string_view bytes, const std::string& field) {
  return stl_triangles(bytes, bytes.size(), field);
}

SurfaceMesh load_mesh(const std::string& path, const std::string& field) {
  if (!std::filesystem::is_regular_file(path))
    throw InvalidInput(field, "cannot read mesh file '" + path + "': no such file");
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext == ".stl") {
    // Only the first bytes and the size are needed: the file is not read twice.
    std::string head(1024, '\0');
    std::ifstream in(path, std::ios::binary);
    in.read(head.data(), static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(in.gcount()));
    stl_triangles(head, std::filesystem::file_size(path), field);
  }
  Assimp::Importer importer;
  // Meshes are welded across the whole scene below; drop every attribute but positions so that
  // assimp's JoinIdenticalVertices welds STL corners (per-face normals would keep them apart).
  importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS,
                              aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                  aiComponent_COLORS | aiComponent_TEXCOORDS |
                                  aiComponent_BONEWEIGHTS | aiComponent_ANIMATIONS |
                                  aiComponent_TEXTURES | aiComponent_LIGHTS |
                                  aiComponent_CAMERAS | aiComponent_MATERIALS);
  const aiScene* scene = importer.ReadFile(
      path, aiProcess_RemoveComponent | aiProcess_DropNormals | aiProcess_Triangulate |
                aiProcess_JoinIdenticalVertices | aiProcess_PreTransformVertices |
                aiProcess_SortByPType);
  if (scene == nullptr)
    throw InvalidInput(field, "cannot read mesh file '" + path + "': " + importer.GetErrorString());

  // Concatenate the triangle meshes, welding identical positions across meshes too.
  std::vector<Vec3> points;
  std::vector<Eigen::Vector3i> tris;
  std::map<std::array<double, 3>, int> index;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if ((mesh->mPrimitiveTypes & aiPrimitiveType_TRIANGLE) == 0) continue;
    std::vector<int> local(mesh->mNumVertices);
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      std::array<double, 3> key{p.x, p.y, p.z};
      auto [it, inserted] = index.emplace(key, static_cast<int>(points.size()));
      if (inserted) points.emplace_back(p.x, p.y, p.z);
      local[v] = it->second;
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) continue;
      tris.emplace_back(local[face.mIndices[0]], local[face.mIndices[1]],
                        local[face.mIndices[2]]);
    }
  }
  if (tris.empty()) throw InvalidInput(field, "mesh file '" + path + "' contains no triangles");
  SurfaceMesh out;
  out.vertices.resize(static_cast<Eigen::Index>(points.size()), 3);
  for (size_t i = 0; i < points.size(); ++i) out.vertices.row(static_cast<Eigen::Index>(i)) = points[i];
  out.faces.resize(static_cast<Eigen::Index>(tris.size()), 3);
  for (size_t i = 0; i < tris.size(); ++i) out.faces.row(static_cast<Eigen::Index>(i)) = tris[i];
  return out;
}

void save_mesh(const SurfaceMesh& mesh, const std::string& path, const std::string& format,
               const std::string& field) {
  static const std::map<std::string, std::string> ids = {
      {"stl", "stlb"}, {"obj", "obj"}, {"ply", "plyb"}, {"glb", "glb2"}};
  auto id = ids.find(format);
  if (id == ids.end())
    throw InvalidInput(field, "unknown mesh format '" + format + "' (use stl, obj, ply or glb)");

  // aiScene's destructor frees everything below, so build it with new[] as assimp expects.
  auto scene = std::make_unique<aiScene>();
  scene->mRootNode = new aiNode();
  scene->mNumMaterials = 1;
  scene->mMaterials = new aiMaterial*[1]{new aiMaterial()};
  scene->mNumMeshes = 1;
  scene->mMeshes = new aiMesh*[1]{new aiMesh()};
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
