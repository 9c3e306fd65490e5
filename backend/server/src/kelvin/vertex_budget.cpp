// The vertex budget of a preparation (kelvin_json.hpp: count_vertices, require_within_budget).
#include "distlab/server/kelvin_json.hpp"

#include <algorithm>
#include <cmath>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/server/http.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "kelvin_codec.hpp"

namespace distlab::server {

double VertexCount::count() const {
  return predicted ? std::min(closed_form, kPredictionMargin * *predicted) : closed_form;
}

VertexCount count_vertices(double closed_form, const mesh::SurfaceMesh* surface, const kelvin::PrepareOptions& options,
                           const Limits& limits, const VertexPredictor& predict) {
  VertexCount c;
  c.closed_form = closed_form;
  if (c.closed_form <= static_cast<double>(limits.max_vertex_estimate) || surface == nullptr || !predict) return c;
  kelvin::PrepareOptions capped = options;  // the prediction's trial meshing stops where the job's would
  capped.max_vertices = std::max<std::size_t>(100, limits.max_vertex_estimate);
  try {
    c.predicted = predict(*surface, capped);
  } catch (const InvalidInput& e) {
    // The mesher's own size refusals name lx: here, over the budget, they are the budget's.
    if (e.field() != "lx") throw;
    c.unpredicted = e.what();
  } catch (const kelvin::Cancelled&) {
    throw;
  } catch (const std::exception& e) {
    c.unpredicted = e.what();
  }
  return c;
}

void require_within_budget(const VertexCount& count, const mesh::SurfaceMesh& surface, const kelvin::PrepareOptions& options,
                           const Limits& limits, const std::string& lx_field, const std::string& far_field) {
  const auto budget = static_cast<double>(limits.max_vertex_estimate);
  const double n = count.count();
  if (n <= budget) return;
  const bool far = options.far_radius > 1 && estimate_vertices(surface, options.lx, 1.0, sizing_for_budget(options)) <= budget;
  const double diagonal = surface.vertices.rows() > 0 ? (surface.vertices.colwise().maxCoeff() - surface.vertices.colwise().minCoeff()).norm() : 0.0;
  const double fits = std::max(limits.min_lx, smallest_lx_within(surface, budget, options.far_radius));
  const std::string how = count.predicted && n < count.closed_form
                              ? " (" + number_text(kPredictionMargin) + " × the " + std::to_string(std::llround(*count.predicted)) + " predicted)"
                          : !count.unpredicted.empty() ? " (the closed-form bound; not predicted: " + count.unpredicted + ")"
                                                       : "";
  const std::string advice =
      far                ? "; use a smaller far_radius"
      : fits <= diagonal ? "; lx " + number_text(fits) + " m or larger fits by the closed form alone (lx_fraction " + number_text(fits / diagonal) + ")"
                         : "; no lx up to the bounding box's diagonal (" + number_text(diagonal) + " m) fits: the surface has too many vertices";
  throw ApiError(422, "over_budget",
                 (far ? "far_radius " + number_text(options.far_radius) : "lx " + number_text(options.lx)) + " would make about " +
                     std::to_string(std::llround(n)) + " vertices" + how + ", over this server's budget of " +
                     std::to_string(limits.max_vertex_estimate) + advice,
                 far ? far_field : lx_field);
}

}  // namespace distlab::server
