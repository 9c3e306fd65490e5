#pragma once
// Temporary folders of the tests, removed when done: a test run leaves /tmp as it found it.
#include <stdlib.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

namespace distlab::test {

// A fresh folder below the system's temporary one (prefix-XXXXXX), removed with everything in it.
class TempDir {
 public:
  explicit TempDir(const std::string& prefix = "distlab-test") {
    std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "-XXXXXX")).string();
    if (::mkdtemp(pattern.data()) == nullptr) throw std::runtime_error("mkdtemp failed: " + pattern);
    path_ = pattern;
  }
  // Only by the process that made it: a forked child that exits must not take its parent's files.
  ~TempDir() {
    std::error_code ec;
    if (::getpid() == owner_) std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::filesystem::path operator/(const std::string& name) const { return std::filesystem::path(path_) / name; }
  // Writes `text` to path()/relative (folders created) and returns the full path.
  std::string write(const std::string& relative, const std::string& text) const {
    const std::filesystem::path p = std::filesystem::path(path_) / relative;
    std::filesystem::create_directories(p.parent_path());
    std::ofstream(p, std::ios::binary) << text;
    return p.string();
  }

 private:
  std::string path_;
  pid_t owner_ = ::getpid();
};

// This test program's folder, made on first use and removed when the program exits.
inline const TempDir& process_temp_dir() {
  static const TempDir dir;
  return dir;
}

// Writes bytes to a file called name in this program's folder and returns its path.
inline std::filesystem::path write_temp_file(const std::string& name, const std::string& bytes) {
  return process_temp_dir().write(name, bytes);
}

}  // namespace distlab::test
