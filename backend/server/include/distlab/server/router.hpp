#pragma once
// A small router: METHOD + pattern with {param} segments -> handler. Unknown path: 404
// unknown_route; known path, other method: 405 with Allow. Exceptions become JSON errors.
#include <functional>
#include <string>
#include <vector>

#include "distlab/server/http.hpp"

namespace distlab::server {

using Handler = std::function<Response(Request&)>;

struct Route {
  std::string method;
  std::string pattern;  // "/api/kelvin/objects/{id}/sigma"
  Handler handler;
  bool heavy = false;          // runs on the compute pool, not on an I/O thread
  std::size_t body_limit = 0;  // 0: the server default
  // Heavy routes: the names of the Limits (GET /api/limits) that bound their work.
  std::vector<std::string> bounds{};
};

class Router {
 public:
  void add(Route route);
  // The route for (method, path), or nullptr; *path_known tells whether another method matches.
  const Route* match(const std::string& method, const std::string& path, Request* fill = nullptr,
                     std::vector<std::string>* allowed = nullptr) const;
  // Matches and runs, mapping ApiError, InvalidInput and every other exception to JSON errors.
  Response dispatch(Request& request) const;
  const std::vector<Route>& routes() const { return routes_; }

 private:
  std::vector<Route> routes_;
};

// Runs fn and maps exceptions to error responses (used by the router and the WebSocket layer).
Response guarded(const std::function<Response()>& fn);

}  // namespace distlab::server
