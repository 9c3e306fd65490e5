// Route matching and exception-to-error mapping.
#include "distlab/server/router.hpp"

#include <cstdio>
#include <new>

#include "distlab/geometry/error.hpp"
#include "distlab/server/json_text.hpp"

namespace distlab::server {
namespace {

std::vector<std::string> segments(const std::string& path) {
  std::vector<std::string> out;
  std::size_t pos = 1;
  while (pos <= path.size()) {
    std::size_t end = path.find('/', pos);
    if (end == std::string::npos) end = path.size();
    out.push_back(path.substr(pos, end - pos));
    pos = end + 1;
  }
  return out;
}

bool matches(const std::string& pattern, const std::string& path, std::map<std::string, std::string>* params) {
  const auto ps = segments(pattern), xs = segments(path);
  if (ps.size() != xs.size()) return false;
  std::map<std::string, std::string> found;
  for (std::size_t i = 0; i < ps.size(); ++i) {
    if (ps[i].size() > 2 && ps[i].front() == '{' && ps[i].back() == '}') {
      if (xs[i].empty()) return false;
      found[ps[i].substr(1, ps[i].size() - 2)] = xs[i];
    } else if (ps[i] != xs[i]) {
      return false;
    }
  }
  if (params) *params = std::move(found);
  return true;
}

}  // namespace

void Router::add(Route route) { routes_.push_back(std::move(route)); }

const Route* Router::match(const std::string& method, const std::string& path, Request* fill,
                           std::vector<std::string>* allowed) const {
  const std::string m = method == "HEAD" ? "GET" : method;
  for (const Route& r : routes_) {
    std::map<std::string, std::string> params;
    if (!matches(r.pattern, path, &params)) continue;
    if (r.method == m) {
      if (fill) fill->params = std::move(params);
      return &r;
    }
    if (allowed) allowed->push_back(r.method);
  }
  return nullptr;
}

Response guarded(const std::function<Response()>& fn) {
  try {
    return fn();
  } catch (const std::exception&) {
    const ErrorAnswer a = error_answer(std::current_exception());
    return error_response(a.status, a.code, a.message, a.field);
  }
}

Response Router::dispatch(Request& request) const {
  return guarded([&] {
    std::vector<std::string> allowed;
    const Route* r = match(request.method, request.path, &request, &allowed);
    if (r == nullptr) {
      if (!allowed.empty()) {
        Response res = error_response(405, "method_not_allowed", request.method + " is not allowed on " + request.path);
        std::string allow;
        for (const auto& a : allowed) allow += (allow.empty() ? "" : ", ") + a;
        res.headers.emplace_back("Allow", allow);
        return res;
      }
      return error_response(404, "unknown_route", "no such endpoint");
    }
    return r->handler(request);
  });
}

}  // namespace distlab::server
