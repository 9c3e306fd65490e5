#pragma once
// Mesh files as bytes, with counts and indices that may lie: binary STL, binary PLY and GLB
// writers shared by the hostile server suite (tests/server) and the fuzzers' seed corpus.
#include <array>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace distlab::test::mesh_bytes {

inline std::string le32(std::uint32_t v) { return std::string(reinterpret_cast<const char*>(&v), 4); }
inline std::string le16(std::uint16_t v) { return std::string(reinterpret_cast<const char*>(&v), 2); }
inline std::string f32(float v) { return std::string(reinterpret_cast<const char*>(&v), 4); }

inline std::string binary_stl(std::uint32_t declared, const std::vector<std::array<float, 9>>& tris, const std::string& header = std::string(80, ' ')) {
  std::string s = header.substr(0, 80);
  s.resize(80, ' ');
  s += le32(declared);
  for (const auto& t : tris) {
    s += f32(0) + f32(0) + f32(0);
    for (float v : t) s += f32(v);
    s += le16(0);
  }
  return s;
}

inline std::string ply_binary(const std::string& vertex_count, const std::string& face_count, const std::vector<float>& xyz,
                              const std::vector<std::vector<std::int64_t>>& faces, const std::string& list_type = "uchar",
                              const std::string& index_type = "int", int forced_count = -1) {
  std::string s = "ply\nformat binary_little_endian 1.0\nelement vertex " + vertex_count +
                  "\nproperty float x\nproperty float y\nproperty float z\nelement face " + face_count +
                  "\nproperty list " + list_type + " " + index_type + " vertex_indices\nend_header\n";
  for (float v : xyz) s += f32(v);
  for (const auto& f : faces) {
    const int n = forced_count >= 0 ? forced_count : static_cast<int>(f.size());
    s += list_type == "uchar" ? std::string(1, static_cast<char>(n)) : le32(static_cast<std::uint32_t>(n));
    for (auto i : f) s += index_type == "int" || index_type == "uint" ? le32(static_cast<std::uint32_t>(i)) : le16(static_cast<std::uint16_t>(i));
  }
  return s;
}

// A GLB with one mesh: positions (float32 VEC3) and indices (uint32 SCALAR); counts can lie.
inline std::string glb(const std::vector<float>& xyz, const std::vector<std::uint32_t>& idx, long pos_count, long idx_count,
                       const std::string& extra_json = "", bool bad_magic = false, long length_delta = 0) {
  std::string bin;
  for (float v : xyz) bin += f32(v);
  const std::size_t pos_bytes = bin.size();
  for (auto i : idx) bin += le32(i);
  while (bin.size() % 4) bin += '\0';
  std::string js =
      "{\"asset\":{\"version\":\"2.0\"},\"scene\":0,\"scenes\":[{\"nodes\":[0]}],\"nodes\":[{\"mesh\":0}],"
      "\"meshes\":[{\"primitives\":[{\"attributes\":{\"POSITION\":0},\"indices\":1}]}],"
      "\"buffers\":[{\"byteLength\":" +
      std::to_string(bin.size()) +
      "}],"
      "\"bufferViews\":[{\"buffer\":0,\"byteOffset\":0,\"byteLength\":" +
      std::to_string(pos_bytes) +
      "},"
      "{\"buffer\":0,\"byteOffset\":" +
      std::to_string(pos_bytes) + ",\"byteLength\":" + std::to_string(idx.size() * 4) +
      "}],"
      "\"accessors\":[{\"bufferView\":0,\"componentType\":5126,\"count\":" +
      std::to_string(pos_count) +
      ",\"type\":\"VEC3\",\"min\":[0,0,0],\"max\":[1,1,1]},"
      "{\"bufferView\":1,\"componentType\":5125,\"count\":" +
      std::to_string(idx_count) + ",\"type\":\"SCALAR\"}]" +
      extra_json + "}";
  while (js.size() % 4) js += ' ';
  std::string s = bad_magic ? "glTX" : "glTF";
  s += le32(2) + le32(static_cast<std::uint32_t>(12 + 8 + js.size() + 8 + bin.size() + length_delta));
  s += le32(static_cast<std::uint32_t>(js.size())) + "JSON" + js;
  s += le32(static_cast<std::uint32_t>(bin.size())) + std::string("BIN\0", 4) + bin;
  return s;
}

}  // namespace distlab::test::mesh_bytes
