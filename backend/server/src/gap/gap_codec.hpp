#pragma once
// The GAP routes' codec (routes_gap.cpp): each route's request read and checked into a typed input
// (decode), and its typed result written as the answer (encode). The distance route's schema is
// gap_json.hpp's, shared with the CLI and the Python bindings.
#include <optional>

#include "distlab/levelset/gap_fields.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/http.hpp"

namespace distlab::server {

// POST /api/gap/distance: the body as decode_gap_request reads it; the answer encode_gap_results'.
GapDistanceRequest decode_gap_distance(const Request& request, const Limits& limits);
Response encode_gap_distance(const GapDistanceResults& results);

// POST /api/gap/levelsets: {"shape", "params", "levels": {"weak", "strict"}, "grid": {"resolution",
// "padding", "bounds": {"min", "max"}}, "plane": {"center", "normal", "size", "resolution"},
// "format": "msgpack" | "json", "comment"}.
struct GapLevelsetsRequest {
  ShapeSpec shape;
  GapRequestParams params;
  levelset::GapLevelsetOptions options;  // levels, grid and plane
  bool msgpack = true;                   // "format": msgpack frames, or json counts and ranges
};
GapLevelsetsRequest decode_gap_levelsets(const Request& request, const Limits& limits);

struct GapLevelsetsResult {
  levelset::GapLevelsets levelsets;
  std::optional<levelset::PlaneFrame> plane;  // where the fields were sampled, if asked
  bool msgpack = true;
};
Response encode_gap_levelsets(const GapLevelsetsResult& result);

}  // namespace distlab::server
