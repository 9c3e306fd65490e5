#pragma once
// Static files from one directory (the front end's web/dist): content types, index.html for
// directories, and no way out of the root (percent-decoded "..", NUL, backslashes and symlinks
// leaving the root are all refused with 404).
#include <string>

#include "distlab/server/http.hpp"

namespace distlab::server {

class StaticFiles {
 public:
  explicit StaticFiles(const std::string& root);
  // GET/HEAD of a path outside /api and /ws. Without an index.html in the root, "/" answers a
  // small built-in page pointing to the API.
  Response serve(const Request& request) const;
  static std::string content_type(const std::string& path);

 private:
  std::string root_;  // canonical, or empty if the directory does not exist
};

}  // namespace distlab::server
