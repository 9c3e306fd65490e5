#pragma once
// A route as data (issue 34): method, path, how its work is run, the limits it names, and three
// functions. decode reads the request (path, query, body) into a typed input and is the only place
// that validates it; handle turns that input into a typed result and never sees JSON or the
// request; encode writes the result as the answer. A feature's routes file is a table of rows
//   {"POST", "/api/gap/distance", Work::heavy, {"max_gap_pairs", ...}, codec(decode, &M::handle, encode)}
// and add_routes() gives the rows to the Router.
#include <cstddef>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "distlab/server/config.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/router.hpp"

namespace distlab::server {

// Who calls: all a handler knows of the HTTP exchange besides its decoded input.
struct Caller {
  std::string session_id;  // Request::session_id(): "" when none was sent
  std::string address;     // the client's IP address ("" when not on a socket)
};

inline Caller caller_of(const Request& request) { return {request.session_id(), request.remote_address}; }

// Where a route's work runs: on the I/O thread (light), or queued on the compute pool (heavy),
// whose queue bounds it (503 busy).
enum class Work { light,
                  heavy };

// A route without input, or without a result beyond its status.
struct Nothing {};
inline Nothing decode_nothing(const Request& /*request*/, const Limits& /*limits*/) { return {}; }
inline Response encode_no_content(const Nothing& /*nothing*/) { return no_content_response(); }  // 204

template <class M>
using RouteRun = std::function<Response(M& owner, Request& request, const Limits& limits)>;

// One row of a table. `bounds`: the Limits (GET /api/limits) that bound a heavy route's work.
template <class M>
struct RouteRow {
  const char* method;
  const char* path;
  Work work;
  std::vector<std::string> bounds;
  RouteRun<M> run;
  std::size_t body_limit = 0;  // 0: the server's max_body_bytes
};

// decode → handle → encode, the three parts of a row. A decode that keeps a large body takes
// `Request&` (Req = Request) and moves it; any other takes `const Request&`.
template <class M, class In, class Out, class Req>
RouteRun<M> codec(In (*decode)(Req&, const Limits&), Out (M::*handle)(const In&, const Caller&),
                  Response (*encode)(const Out&)) {
  return [decode, handle, encode](M& owner, Request& request, const Limits& limits) {
    const In input = decode(request, limits);
    return encode((owner.*handle)(input, caller_of(request)));
  };
}

// The same for a decode that also reads the server's assets (scenarios and robots by name):
// owner.assets_dir() gives it.
template <class M, class In, class Out, class Req>
RouteRun<M> codec(In (*decode)(Req&, const Limits&, const std::string& assets_dir), Out (M::*handle)(const In&, const Caller&),
                  Response (*encode)(const Out&)) {
  return [decode, handle, encode](M& owner, Request& request, const Limits& limits) {
    const In input = decode(request, limits, owner.assets_dir());
    return encode((owner.*handle)(input, caller_of(request)));
  };
}

template <class M>
void add_routes(Router& router, M& owner, const Limits& limits, std::vector<RouteRow<M>> rows) {
  for (auto& row : rows) {
    Route route{row.method, row.path,
                [&owner, &limits, run = std::move(row.run)](Request& request) { return run(owner, request, limits); }};
    route.heavy = row.work == Work::heavy;
    route.bounds = std::move(row.bounds);
    route.body_limit = row.body_limit;
    router.add(std::move(route));
  }
}

}  // namespace distlab::server
