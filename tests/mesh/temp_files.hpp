#pragma once
// Files the mesh tests write for the importer to read: one folder per test process.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace distlab::test {

// Writes bytes to a file called name in this process's temporary folder and returns its path.
inline std::filesystem::path write_temp_file(const std::string& name, const std::string& bytes) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / ("distlab_mesh_files_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  const std::filesystem::path path = dir / name;
  std::ofstream(path, std::ios::binary) << bytes;
  return path;
}

}  // namespace distlab::test
