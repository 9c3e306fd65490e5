#pragma once
// Mesh files for the importer's tests, as bytes: a small mesh whose file order differs from the
// order its faces meet the vertices, and hostile files (bad counts, indices, list lengths,
// non-finite coordinates). Used by tests/mesh and the server's upload tests.
#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <utility>
#include <vector>

namespace distlab::test {

template <typename T>
inline void put(std::string& out, T value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

// A tetrahedron whose file lists its vertices so that the faces meet them last to first, plus a
// sixth vertex repeating vertex 1's position, used by the last face instead of vertex 1.
inline const std::vector<std::array<double, 3>> kFileVertices = {
    {0, 0, 1}, {0, 1, 0}, {1, 0, 0}, {0, 0, 0}, {0.5, 0.25, 0.25}, {0, 1, 0}};
inline const std::vector<std::array<int, 3>> kFileFaces = {{3, 2, 0}, {3, 1, 2}, {3, 0, 1}, {2, 5, 0}};

inline std::string obj_text() {
  std::string s = "# file order differs from face-walk order\n";
  for (const auto& v : kFileVertices) s += "v " + std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + "\n";
  for (const auto& f : kFileFaces) s += "f " + std::to_string(f[0] + 1) + " " + std::to_string(f[1] + 1) + " " + std::to_string(f[2] + 1) + "\n";
  return s;
}

inline std::string off_text() {
  std::string s = "OFF\n" + std::to_string(kFileVertices.size()) + " " + std::to_string(kFileFaces.size()) + " 0\n";
  for (const auto& v : kFileVertices) s += std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + "\n";
  for (const auto& f : kFileFaces) s += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
  return s;
}

inline std::string ply_header(const std::string& format, std::size_t nv, std::size_t nf, const std::string& list = "uchar int") {
  return "ply\nformat " + format + " 1.0\nelement vertex " + std::to_string(nv) +
         "\nproperty float x\nproperty float y\nproperty float z\nelement face " + std::to_string(nf) +
         "\nproperty list " + list + " vertex_indices\nend_header\n";
}

inline std::string ply_ascii() {
  std::string s = ply_header("ascii", kFileVertices.size(), kFileFaces.size());
  for (const auto& v : kFileVertices) s += std::to_string(v[0]) + " " + std::to_string(v[1]) + " " + std::to_string(v[2]) + "\n";
  for (const auto& f : kFileFaces) s += "3 " + std::to_string(f[0]) + " " + std::to_string(f[1]) + " " + std::to_string(f[2]) + "\n";
  return s;
}

inline std::string ply_binary() {
  std::string s = ply_header("binary_little_endian", kFileVertices.size(), kFileFaces.size());
  for (const auto& v : kFileVertices)
    for (double x : v) put(s, static_cast<float>(x));
  for (const auto& f : kFileFaces) {
    put(s, std::uint8_t{3});
    for (int i : f) put(s, static_cast<std::int32_t>(i));
  }
  return s;
}

// Hostile files: (format, bytes). The last two have a NaN and an infinite coordinate.
inline std::vector<std::pair<std::string, std::string>> hostile_meshes() {
  std::vector<std::pair<std::string, std::string>> files = {
      {"ply", ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 1 5\n"},   // index out of range
      {"ply", ply_header("ascii", 3, 1) + "0 0 0\n1 0 0\n0 1 0\n3 0 -1 2\n"},  // negative index
      {"off", "OFF\n3 1 0\n0 0 0\n"},                                          // 16 bytes
      {"off", "OFF\n1000000000 1 0\n0 0 0\n3 0 0 0 \n"},                       // 34 bytes, 1e9 vertices
      {"off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n2000000000 0 1 2\n"},          // a face of 2e9 vertices
      {"off", "OFF\n3 1 0\n0 0 0\n1 0 0\n0 1 0\n3 0 1 -2\n"},
      {"off", "4OFF\n3 1 0\n0 0 0 0\n1 0 0 1\n0 1 0 1\n3 0 1 2\n"},  // w = 0: 0/0
      {"ply", ply_header("ascii", 4294967295u, 1) + "0 0 0\n3 0 0 0\n"},
      {"ply", ply_header("binary_little_endian", 4294967295u, 1) + std::string(64, '\0')},
      // An integer coordinate: CGAL's reader dereferenced a null pointer on it (found by fuzzing).
      {"ply",
       "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty int32 z\nelement face 1\n"
       "property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n"},
      {"obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"},
      {"obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -9 1 2\n"},
      {"obj", "v 1e999 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n"},
  };
  // Binary PLY whose face list says 255 (uchar): 3 indices follow, or 255 wild ones.
  std::string b = ply_header("binary_little_endian", 3, 1);
  for (int i = 0; i < 9; ++i) put(b, static_cast<float>(i % 4 == 0));
  put(b, std::uint8_t{255});
  std::string wild = b;
  for (int i = 0; i < 3; ++i) put(b, static_cast<std::int32_t>(i));
  for (int i = 0; i < 255; ++i) put(wild, std::int32_t{0x7fffffff});
  files.emplace_back("ply", b);
  files.emplace_back("ply", wild);
  // A uint list count of 4294967295 and a NaN coordinate, binary.
  std::string uint_list = ply_header("binary_little_endian", 3, 1, "uint int");
  for (int i = 0; i < 9; ++i) put(uint_list, static_cast<float>(i % 4 == 0));
  put(uint_list, std::uint32_t{4294967295u});
  for (int i = 0; i < 3; ++i) put(uint_list, static_cast<std::int32_t>(i));
  files.emplace_back("ply", uint_list);
  std::string nan = ply_header("binary_little_endian", 3, 1);
  for (int i = 0; i < 9; ++i) put(nan, i == 4 ? std::numeric_limits<float>::quiet_NaN() : static_cast<float>(i % 4 == 0));
  put(nan, std::uint8_t{3});
  for (int i = 0; i < 3; ++i) put(nan, static_cast<std::int32_t>(i));
  files.emplace_back("ply", nan);
  // Binary STL with an infinite coordinate.
  std::string stl(80, '\0');
  put(stl, std::uint32_t{1});
  for (int i = 0; i < 12; ++i) put(stl, i == 5 ? std::numeric_limits<float>::infinity() : 0.5f * static_cast<float>(i % 4));
  put(stl, std::uint16_t{0});
  files.emplace_back("stl", stl);
  return files;
}

}  // namespace distlab::test
