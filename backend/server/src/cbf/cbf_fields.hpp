#pragma once
// A scenario's Kelvin objects and control points (cbf/fields.hpp) as JSON:
//   "fields": [{"name"?, "mesh": {"asset": NAME} | {"path": FILE}, "lx" | "lx_fraction",
//               "grading"?, "center"?, "far_radius"?, "feature_angle"?, "components"?, "simplify"?,
//               "repair"?, "repair_options"? (ReshapeRequest, as the Kelvin requests),
//               "pose"?: {"position", "quaternion"}, "sigma"?: SIGMA (as the Kelvin requests:
//               per_vertex in the file's vertex order, axis terms, brushes), "delta"?: δ (0)}]
//   "control_points": [{"link", "point": [x, y, z] (link frame), "name"?}
//                      | {"link", "element"?: NAME, "sample": COUNT}]
// and the request's "params": {"fields": [{"sigma"?, "delta"?}, ...] (by index: replaces the
// scenario's), "field_mode": "barrier" (default) | "hull" (each field's object becomes its
// convex hull, an obstacle: the comparison without semantics; its control points are unused)}.
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/cbf/rollout.hpp"
#include "distlab/server/cbf_json.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace distlab::server {

// A field entry read and checked up to its repair and preparation. The service plans a request
// so on the request thread (its errors are the request's) and prepares in the rollout's job.
struct PlannedField {
  std::string field;             // its path, "scenario.fields[i]"
  std::string lx_field;          // the key that set l_x: FIELD.lx or FIELD.lx_fraction
  std::string key;               // the entry's JSON (params applied) and mesh file: equal keys, equal fields
  cbf::SceneField scene;         // name, pose, δ, σ over `prepared`'s vertices; no field yet
  mesh::SurfaceMesh surface;     // as the file gives it (its vertices in its order)
  kelvin::SigmaSpec user_sigma;  // σ as given (per_vertex per file vertex)
  mesh::SurfaceMesh prepared;    // the welded surface: what is prepared (unless reshaped)
  kelvin::PrepareOptions options;
  ReshapeRequest reshape;
};
// A scenario's fields and control points (checked against the robot) before preparation.
struct FieldPlan {
  std::vector<PlannedField> fields;
  std::vector<cbf::ControlPoint> control_points;
};

// parse_scenario_fields in two halves: plan (read and check; field_mode "hull" adds the hulls to
// s.obstacles at once), then prepare (repair, prepare, solve σ; fields and control points into s).
// prepared: fields made before, by PlannedField::key, reused and added to (a sweep's runs share
// them). progress: repair stage "repair", σ stage "solve"; the preparer reports its own.
void plan_scenario_fields(const nlohmann::json& j, const std::string& field, const std::string& assets_dir,
                          const Limits& limits, FieldPlan& plan, cbf::Scenario& s);
void prepare_planned_fields(cbf::Scenario& s, const FieldPlan& plan, const FieldPreparer& prepare,
                            const Progress& progress = {}, std::map<std::string, cbf::SceneField>* prepared = nullptr);
// parse_cbf_request and parse_cbf_sweep with the fields planned, not prepared: the scenarios have
// neither fields nor control points until prepare_planned_fields (one plan per run).
CbfRequest plan_cbf_request(const nlohmann::json& request, const std::string& assets_dir, FieldPlan& plan,
                            const Limits& limits);
CbfSweep plan_cbf_sweep(const nlohmann::json& request, const std::string& assets_dir, const Limits& limits,
                        std::vector<FieldPlan>& plans);

// Applies params.fields and params.field_mode to a scenario's JSON before it is parsed.
void apply_field_params(nlohmann::json& scenario, const nlohmann::json& params);

// The record's Kelvin part: {"control_points": [{"name", "link", "point"}], "fields": [{"name",
// "delta", "safety_distance" (FieldSurface::forbidden_offset at δ), "h": [[per point] per step], "closest": [[x,y,z] per step], "closest_sigma": [...],
// "distance": [...], "closest_control_point": [index per step], "allowed_distance": [...],
// "forbidden_distance": [...], "summary": {"min_h", "min_h_over_delta", "final_distance",
// "final_allowed_distance", "min_forbidden_distance"}}], "failure"?: {"step", "message"}}; null
// entries where undefined.
nlohmann::json encode_fields(const cbf::RolloutRecord& record);
// Its pieces: the control points, and one field's values at one step ({"h": [per point],
// "closest", "closest_sigma", "distance", "closest_control_point", "allowed_distance",
// "forbidden_distance"}), which a streamed frame carries per field and the record as columns.
nlohmann::json encode_control_points(const std::vector<cbf::ControlPoint>& points);
nlohmann::json encode_field_step(const cbf::StepRecord& step, std::size_t field, std::size_t points);

}  // namespace distlab::server
