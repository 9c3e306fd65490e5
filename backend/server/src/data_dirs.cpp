#include "distlab/server/data_dirs.hpp"

#include <cstdlib>
#include <filesystem>
#include <stdexcept>

namespace distlab::server {

namespace fs = std::filesystem;

std::vector<std::string> data_dir_candidates(const char* env, const std::string& relative, const std::string& installed) {
  std::vector<std::string> out;
  if (const char* v = env != nullptr ? std::getenv(env) : nullptr; v != nullptr && *v) out.emplace_back(v);
  out.push_back(relative);
  std::error_code ec;
  // /proc/self/exe: the binary, wherever it was started from (build tree or installed).
  for (fs::path p = fs::read_symlink("/proc/self/exe", ec).parent_path(); !ec && !p.empty(); p = p.parent_path()) {
    out.push_back((p / relative).string());
    out.push_back((p / "share/distlab" / installed).string());  // cmake --install's layout
    if (p == p.root_path()) break;
  }
  return out;
}

std::string find_data_dir(const std::string& option, const char* env, const std::string& relative,
                          const std::string& installed, const std::string& given) {
  std::error_code ec;
  if (!given.empty()) {
    if (fs::is_directory(given, ec)) return given;
    throw std::runtime_error(option + " " + given + ": no such directory");
  }
  for (const auto& dir : data_dir_candidates(env, relative, installed))
    if (fs::is_directory(dir, ec)) return dir;
  throw std::runtime_error("no " + relative + " directory found (looked at $" + std::string(env) + ", ./" + relative +
                           ", " + relative + " and share/distlab/" + installed + " beside the binary and above it); give " + option + " DIR");
}

std::string default_cache_dir() {
  if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg != nullptr && *xdg) return std::string(xdg) + "/distlab";
  if (const char* home = std::getenv("HOME"); home != nullptr && *home) return std::string(home) + "/.cache/distlab";
  return "";
}

}  // namespace distlab::server
