#pragma once
// The JSON schema of Kelvin requests (issue 3), shared by `distlab kelvin` and later the server.
//
// Request:  {"mesh": {"path": FILE} | {"asset": NAME}, "lx": number, "center": [x, y, z]?,
//            "far_radius": number?, "cache": DIR?,
//            "sigma": {"constant"?, "per_vertex"?: [one per vertex of the file, in its order;
//                      vertices at one position carry one value],
//                      "axis"?: AXIS | [AXIS, ...], "brushes"?: [BRUSH, ...]} (terms add up; brushes
//                      apply in order, "towards" ones move σ towards their value),
//            "query": [[x, y, z], ...]?,
//            "isosurfaces": {"levels": [...], "format": "ply"|"stl"|"obj"|"glb", "path": FILE}?}
//            AXIS = {"axis": [x,y,z], "d0", "sigma_nom", "origin"?: [x,y,z], "width"?} (eq. 24)
//            BRUSH = {"center": [x,y,z], "radius", "value", "falloff"?, "mode"?: "add"|"towards"}
// Response: {"stats": {"n_verts", "n_tets", "size_mb", "t_mesh", "t_build", "t_decomp",
//            "t_solve", "cache_hit"}, "mesh": {"n_vertices", "n_faces", "n_welded_vertices"},
//            "query": {"h": [...], "gradient": [[...], ...], "inside": [...]},
//            "isosurfaces": [{"level", "path", "n_verts", "n_faces", "digest"}, ...]}.
//            A level the field never takes (at or below its minimum) is an error naming it.
//            h and gradient are null where undefined (inside, or V ≤ 0 there).
//            With several levels the files are PATH-stem_<i>.ext, one per level.
// Errors:   {"error": {"code", "message", "field"}} as for GAP.
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"

namespace distlab::server {

// Runs a whole request. Throws InvalidInput (with the field) on bad input.
nlohmann::json run_kelvin_request(const nlohmann::json& request, const kelvin::Progress& progress = {});

// Parses the "sigma" object (field prefix "sigma").
kelvin::SigmaSpec parse_sigma(const nlohmann::json& j);

// Finds an asset by name: $DISTLAB_ASSETS, ./assets, or an assets/ folder above the executable.
std::string asset_path(const std::string& name);

}  // namespace distlab::server
