#pragma once
// Typed reads of request fields shared by the JSON codecs and routes: each names the field in its
// InvalidInput, and refuses non-finite numbers.
#include <cmath>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/types.hpp"

namespace distlab::server {

inline double json_number(const nlohmann::json& j, const std::string& field) {
  if (!j.is_number()) throw InvalidInput(field, field + " must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InvalidInput(field, field + " must be finite");
  return v;
}

inline Vec3 json_vec3(const nlohmann::json& j, const std::string& field) {
  if (!j.is_array() || j.size() != 3)
    throw InvalidInput(field, field + " must be an array of 3 numbers");
  return {json_number(j[0], field + "[0]"), json_number(j[1], field + "[1]"),
          json_number(j[2], field + "[2]")};
}

}  // namespace distlab::server
