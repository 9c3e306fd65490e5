// GAP endpoints: distances (the CLI's schema) and level sets of e_S / E_S.

#include "distlab/gap/point_to_set.hpp"
#include "distlab/levelset/gap_fields.hpp"
#include "distlab/server/deadline.hpp"
#include "gap_module.hpp"

namespace distlab::server {

void GapModule::register_routes() {
  using M = GapModule;
  // A row per route, as a table.
  // clang-format off
  add_routes<M>(router_, *this, config_.limits, {
    {"POST", "/api/gap/distance", Work::heavy, {"max_body_bytes", "max_gap_pairs", "max_gap_iterations", "max_request_seconds"},
     codec(decode_gap_distance, &M::distance, encode_gap_distance)},
    {"POST", "/api/gap/levelsets", Work::heavy, {"max_body_bytes", "max_levels", "max_grid_resolution", "max_plane_resolution", "max_request_seconds"},
     codec(decode_gap_levelsets, &M::levelsets, encode_gap_levelsets)},
  });
  // clang-format on
}

GapDistanceResults GapModule::distance(const GapDistanceRequest& request, const Caller& /*caller*/) {
  const Deadline deadline(config_.limits.max_request_seconds);
  return compute_gap_request(request, [&] { deadline.check("send fewer pairs per request"); });
}

GapLevelsetsResult GapModule::levelsets(const GapLevelsetsRequest& request, const Caller& /*caller*/) {
  const GapParams& params = request.params.params;
  P2SOptions options = request.shape.options;
  options.weight_margin = params.weight_margin;
  PointToSet p2s(request.shape.shape, BaseFunction(params.h, params.k), StrictParams{params.eps, params.sigma}, options, "shape");
  p2s.set_pose(request.shape.pose);

  // Time per request: the sampling stops (408) once the deadline passes.
  const Deadline deadline(config_.limits.max_request_seconds);
  Progress progress;
  progress.report = [&deadline](const std::string&, double) { deadline.check("use a coarser grid"); };
  return {levelset::gap_levelsets(p2s, request.options, progress), request.options.plane, request.msgpack};
}

}  // namespace distlab::server
