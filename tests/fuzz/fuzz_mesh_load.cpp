// libFuzzer: the mesh loader, bytes -> file -> distlab::mesh::load_mesh (the upload path). The
// format is sniffed from the bytes as an uploader would name it, so every importer is reached.
// A refusal (InvalidInput, any exception the server maps to a 4xx/5xx) is fine; a crash, a
// sanitizer report, an allocation over -malloc_limit_mb or a timeout is a finding.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstring>
#include <exception>
#include <fstream>
#include <string>
#include <string_view>

#include "distlab/mesh/surface.hpp"

namespace {

const char* extension(std::string_view b) {
  if (b.rfind("glTF", 0) == 0) return ".glb";
  if (b.rfind("ply", 0) == 0) return ".ply";
  if (b.substr(0, 8).find("OFF") != std::string_view::npos) return ".off";
  if (b.rfind("solid", 0) == 0) return ".stl";
  if (!b.empty() && static_cast<unsigned char>(b[0]) < 0x20 && b[0] != '\n' && b[0] != '\r' && b[0] != '\t' && b[0] != ' ')
    return ".stl";  // binary: an 80-byte header usually starts with anything
  if (b.size() >= 84) {
    std::uint32_t n;
    std::memcpy(&n, b.data() + 80, 4);
    if (b.size() == 84 + 50ull * n) return ".stl";
  }
  return ".obj";
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view bytes(reinterpret_cast<const char*>(data), size);
  static const std::string base = [] {
    const char* dir = std::getenv("TMPDIR");
    return std::string(dir ? dir : "/tmp") + "/distlab-fuzz-mesh-" + std::to_string(::getpid());
  }();
  const std::string path = base + extension(bytes);
  {
    std::ofstream f(path, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  try {
    const distlab::mesh::SurfaceMesh m = distlab::mesh::load_mesh(path, "body");
    // What the loader returns must index its own vertices.
    if (m.faces.size() > 0 && (m.faces.minCoeff() < 0 || m.faces.maxCoeff() >= m.vertices.rows())) __builtin_trap();
  } catch (const std::exception&) {
  }
  std::remove(path.c_str());
  return 0;
}
