// A decoded GAP distance request run (compute_gap_request, gap_json.hpp): each distinct shape built
// and checked once, the pairs solved in chunks, the Euclidean penetration of overlapping pairs.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <optional>
#include <stdexcept>
#include <utility>
#include <vector>

#include "distlab/geometry/parallel.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"

namespace distlab::server {
namespace {

using BodyPair = std::pair<const GapBody*, const GapBody*>;

// Pairs between two checks of the time limit (each chunk runs on all cores).
constexpr std::size_t kChunk = 64;

bool finite(const GapResult& r) {
  const auto& e = r.euclidean;
  return std::isfinite(r.lambda) && std::isfinite(r.distance) && r.witness_a.allFinite() &&
         r.witness_b.allFinite() && r.gradient_a.allFinite() && r.gradient_b.allFinite() &&
         std::isfinite(e.distance) && e.witness_a.allFinite() && e.witness_b.allFinite() &&
         e.gradient_a.allFinite() && e.gradient_b.allFinite();
}

bool finite(const std::optional<Penetration>& pen) {
  return !pen || (std::isfinite(pen->depth) && pen->witness_a.allFinite() && pen->witness_b.allFinite());
}

// Each distinct shape's body (at the origin), on all cores; the lowest failing index wins.
std::vector<GapBody> build_bodies(const GapDistanceRequest& request) {
  std::vector<std::optional<GapBody>> built(request.shapes.size());
  parallel_for(built.size(), 0, [&](std::size_t k) {
    const ShapeSpec& spec = request.shapes[k];
    built[k].emplace(spec.shape, Pose{}, request.params.params, spec.options, request.shape_fields[k]);
  });
  std::vector<GapBody> bodies;
  bodies.reserve(built.size());
  for (auto& b : built) bodies.push_back(std::move(*b));
  return bodies;
}

// Property 2 of each distinct shape; the first that fails is InvalidInput naming where it appears.
std::vector<ValidationReport> validate_bodies(const GapDistanceRequest& request, const std::vector<GapBody>& bodies) {
  std::vector<ValidationReport> reports(bodies.size());
  parallel_for(bodies.size(), 0, [&](std::size_t k) { reports[k] = validate_p2s(bodies[k].p2s()); });
  for (std::size_t k = 0; k < reports.size(); ++k)
    if (!reports[k].ok) throw InvalidInput(request.shape_fields[k], reports[k].message);
  return reports;
}

// The Euclidean penetration (depth, direction, witness points) of each overlapping pair from
// `begin` on, beside Λ = 0.
void add_penetrations(const std::vector<BodyPair>& pairs, std::size_t begin, const std::function<void()>& check,
                      GapDistanceResults& out) {
  out.penetrations.resize(out.results.size());
  parallel_for(out.results.size() - begin, 0, [&](std::size_t k) {
    const std::size_t i = begin + k;
    if (out.results[i].euclidean_computed && out.results[i].euclidean.distance == 0) {
      check();  // per pair too: one deep overlap of many-faceted shapes can take seconds
      out.penetrations[i] = penetration(pairs[i].first->euclidean(), pairs[i].first->pose(),
                                        pairs[i].second->euclidean(), pairs[i].second->pose());
    }
  });
}

// One pair alone, or a batch in chunks (so the checkpoint runs while a long batch is under way),
// each chunk's penetrations before the next (a deep overlap of round shapes costs ms).
void solve_pairs(const std::vector<BodyPair>& pairs, bool batch, const GapParams& params,
                 const std::function<void()>& check, GapDistanceResults& out) {
  if (!batch) {
    out.results.push_back(gap_distance(*pairs[0].first, *pairs[0].second, params));
    add_penetrations(pairs, 0, check, out);
    return;
  }
  out.results.reserve(pairs.size());
  for (std::size_t begin = 0; begin < pairs.size(); begin += kChunk) {
    check();
    const std::vector<BodyPair> chunk(pairs.begin() + static_cast<std::ptrdiff_t>(begin),
                                      pairs.begin() + static_cast<std::ptrdiff_t>(std::min(pairs.size(), begin + kChunk)));
    for (GapResult& r : gap_distance_batch(chunk, params)) out.results.push_back(std::move(r));
    add_penetrations(pairs, begin, check, out);
  }
}

}  // namespace

GapDistanceResults compute_gap_request(const GapDistanceRequest& request, const std::function<void()>& checkpoint) {
  const auto check = [&] {
    if (checkpoint) checkpoint();
  };
  const std::vector<GapBody> shapes = build_bodies(request);
  check();
  std::vector<ValidationReport> reports;
  if (request.params.validate) {
    reports = validate_bodies(request, shapes);
    check();
  }

  std::vector<GapBody> bodies;
  bodies.reserve(request.instances.size());  // no reallocation: the pairs below point into it
  for (const GapShapeInstance& instance : request.instances) {
    bodies.push_back(shapes[instance.shape]);
    bodies.back().set_pose(instance.pose);
  }
  std::vector<BodyPair> pairs;
  for (std::size_t i = 0; i + 1 < bodies.size(); i += 2) pairs.emplace_back(&bodies[i], &bodies[i + 1]);

  GapDistanceResults out;
  out.batch = request.batch;
  out.gradient = request.params.params.gradient;
  solve_pairs(pairs, request.batch, request.params.params, check, out);
  for (std::size_t i = 0; i < out.results.size(); ++i) {
    if (!finite(out.results[i]) || !finite(out.penetrations[i]))
      throw std::runtime_error(
          "non-finite result for " + (request.batch ? json_index_path("pairs", i) : std::string("the pair")) +
          "; refusing to report it" +
          (request.params.validate ? "" : " (validate is off: parameters that break Property 2 can do this)"));
    if (request.params.validate)
      out.validation.emplace_back(reports[request.instances[2 * i].shape], reports[request.instances[2 * i + 1].shape]);
  }
  return out;
}

}  // namespace distlab::server
