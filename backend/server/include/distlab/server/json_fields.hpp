#pragma once
// Typed reads of request fields shared by the JSON codecs and routes: each names the field in its
// InvalidInput (a path such as "scenario.obstacles[2].shape.size[1]"), and refuses non-finite
// numbers. At the end, the writers of the numbers the codecs answer with.
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/pose.hpp"
#include "distlab/geometry/types.hpp"

namespace distlab::server {

// "base.key" (or "key" at the top level) and "base[i]".
inline std::string json_key_path(const std::string& base, const std::string& key) {
  return base.empty() ? key : base + "." + key;
}
inline std::string json_index_path(const std::string& base, std::size_t i) {
  return base + "[" + std::to_string(i) + "]";
}

// Largest |coordinate| of positions, sizes, vertices, centres and ρ balls in any request: keeps
// squares and sums far from overflow, so a huge input is refused instead of producing an inf
// downstream. A property of the format (a coordinate is metres in [-1e6, 1e6], in the CLI's files
// and the Python bindings as on the wire), not a server limit: it bounds no resource, and the
// numerics' finiteness rests on it, so it is no entry of the limits table for a server to raise.
inline constexpr double kMaxCoordinate = 1e6;

// A finite number; |v| <= max_abs when given (e.g. kMaxCoordinate keeps squares finite).
inline double json_number(const nlohmann::json& j, const std::string& field,
                          double max_abs = std::numeric_limits<double>::infinity()) {
  if (!j.is_number()) throw InvalidInput(field, field + " must be a number, got " + j.type_name());
  const double v = j.get<double>();
  if (!std::isfinite(v)) throw InvalidInput(field, field + " must be finite");
  if (std::abs(v) > max_abs)
    throw InvalidInput(field, field + " must have magnitude <= " + nlohmann::json(max_abs).dump());
  return v;
}

// A number > 0 (sizes, radii, heights), |v| <= max_abs.
inline double json_positive(const nlohmann::json& j, const std::string& field,
                            double max_abs = std::numeric_limits<double>::infinity()) {
  const double v = json_number(j, field, max_abs);
  if (!(v > 0)) throw InvalidInput(field, field + " must be > 0, got " + nlohmann::json(v).dump());
  return v;
}

// An integer in [lo, hi]; a float with an integral value (e.g. 3.0) counts as one.
inline int json_integer(const nlohmann::json& j, const std::string& field,
                        long long lo = std::numeric_limits<int>::min(),
                        long long hi = std::numeric_limits<int>::max()) {
  if (!j.is_number()) throw InvalidInput(field, field + " must be an integer, got " + j.type_name());
  const double v = j.get<double>();
  if (j.is_number_float() && !(std::isfinite(v) && v == std::floor(v)))
    throw InvalidInput(field, field + " must be an integer, got " + j.dump());
  if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)))
    throw InvalidInput(field, field + " must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "], got " +
                                  j.dump());
  return j.is_number_float() ? static_cast<int>(v) : static_cast<int>(j.get<long long>());
}

// An array of at most max elements (`what` names them in the message, e.g. "pairs").
inline const nlohmann::json& json_array(const nlohmann::json& j, const std::string& field, std::size_t max,
                                        const std::string& what = "elements") {
  if (!j.is_array()) throw InvalidInput(field, field + " must be an array, got " + j.type_name());
  if (j.size() > max)
    throw InvalidInput(field, field + " has " + std::to_string(j.size()) + " " + what + ", above the limit of " +
                                  std::to_string(max));
  return j;
}

inline bool json_bool(const nlohmann::json& j, const std::string& field) {
  if (!j.is_boolean()) throw InvalidInput(field, field + " must be true or false, got " + j.type_name());
  return j.get<bool>();
}

inline std::string json_string(const nlohmann::json& j, const std::string& field) {
  if (!j.is_string()) throw InvalidInput(field, field + " must be a string, got " + j.type_name());
  return j.get<std::string>();
}

// A fixed-size vector of finite numbers (each > 0 when `positive`).
template <int N>
Eigen::Matrix<double, N, 1> json_vec(const nlohmann::json& j, const std::string& field,
                                     double max_abs = std::numeric_limits<double>::infinity(),
                                     bool positive = false) {
  if (!j.is_array() || j.size() != N)
    throw InvalidInput(field, field + " must be an array of " + std::to_string(N) + " numbers, got " +
                                  (j.is_array() ? std::to_string(j.size()) + " elements" : j.type_name()));
  Eigen::Matrix<double, N, 1> v;
  for (int i = 0; i < N; ++i) {
    const auto& e = j[static_cast<std::size_t>(i)];
    const std::string f = json_index_path(field, static_cast<std::size_t>(i));
    v[i] = positive ? json_positive(e, f, max_abs) : json_number(e, f, max_abs);
  }
  return v;
}

// A vector of exactly n finite numbers (n known at run time: a robot's joints).
inline Eigen::VectorXd json_vecx(const nlohmann::json& j, const std::string& field, int n,
                                 double max_abs = std::numeric_limits<double>::infinity()) {
  if (!j.is_array() || j.size() != static_cast<std::size_t>(n))
    throw InvalidInput(field, field + " must be an array of " + std::to_string(n) + " numbers, got " +
                                  (j.is_array() ? std::to_string(j.size()) + " elements" : j.type_name()));
  Eigen::VectorXd v(n);
  for (int i = 0; i < n; ++i)
    v[i] = json_number(j[static_cast<std::size_t>(i)], json_index_path(field, static_cast<std::size_t>(i)), max_abs);
  return v;
}

inline Vec3 json_vec3(const nlohmann::json& j, const std::string& field,
                      double max_abs = std::numeric_limits<double>::infinity()) {
  return json_vec<3>(j, field, max_abs);
}

inline void json_require_object(const nlohmann::json& j, const std::string& field) {
  if (!j.is_object())
    throw InvalidInput(field, (field.empty() ? std::string("the request") : field) +
                                  " must be an object, got " + j.type_name());
}

// j[key], or InvalidInput naming "field.key" when it is missing.
inline const nlohmann::json& json_required(const nlohmann::json& j, const std::string& field,
                                           const std::string& key) {
  const auto it = j.find(key);
  if (it == j.end()) throw InvalidInput(json_key_path(field, key), "missing required key \"" + key + "\"");
  return *it;
}

// &j[key], or nullptr when the optional key is absent.
inline const nlohmann::json* json_optional(const nlohmann::json& j, const std::string& key) {
  const auto it = j.find(key);
  return it == j.end() ? nullptr : &*it;
}

// Refuses keys outside `allowed` (strict schemas catch typos such as "duraton").
template <class Range>
void json_check_keys(const nlohmann::json& j, const std::string& field, const Range& allowed) {
  for (const auto& [key, value] : j.items())
    if (std::find(std::begin(allowed), std::end(allowed), key) == std::end(allowed)) {
      std::string list;
      for (const auto& a : allowed) list += (list.empty() ? "" : ", ") + std::string(a);
      throw InvalidInput(json_key_path(field, key.substr(0, 64)),
                         "unknown key \"" + key.substr(0, 64) + "\" (allowed here: " + list + ")");
    }
}
inline void json_check_keys(const nlohmann::json& j, const std::string& field,
                            std::initializer_list<std::string_view> allowed) {
  json_check_keys<std::initializer_list<std::string_view>>(j, field, allowed);
}

// Below this norm a quaternion is no rotation: refused rather than normalised into noise.
inline constexpr double kMinQuaternionNorm = 1e-9;

// The one pose reader: {"position": [x, y, z], "quaternion": [w, x, y, z]}, |position| <=
// kMaxCoordinate, the quaternion normalised; an absent one is the identity's, unless
// position_required (a target is nowhere without its position).
inline Pose json_pose(const nlohmann::json& j, const std::string& field, bool position_required = false) {
  json_require_object(j, field);
  json_check_keys(j, field, {"position", "quaternion"});
  Pose pose;
  const nlohmann::json* position =
      position_required ? &json_required(j, field, "position") : json_optional(j, "position");
  if (position != nullptr) pose.position = json_vec3(*position, json_key_path(field, "position"), kMaxCoordinate);
  if (const nlohmann::json* q = json_optional(j, "quaternion")) {
    const std::string qf = json_key_path(field, "quaternion");
    if (!q->is_array() || q->size() != 4)
      throw InvalidInput(qf, "expected [w, x, y, z] (4 numbers), got " +
                                 (q->is_array() ? std::to_string(q->size()) + " elements" : std::string(q->type_name())));
    Eigen::Vector4d c;
    for (std::size_t i = 0; i < 4; ++i) c[static_cast<Eigen::Index>(i)] = json_number((*q)[i], json_index_path(qf, i));
    double norm = c.stableNorm();
    if (std::isinf(norm)) {  // |q| beyond a double's range (all four 1e308): q / |q| was the zero quaternion
      c /= c.cwiseAbs().maxCoeff();
      norm = c.stableNorm();
    }
    if (!(norm >= kMinQuaternionNorm)) throw InvalidInput(qf, "quaternion has (near) zero norm; it must be a rotation");
    pose.rotation = Quat(c[0] / norm, c[1] / norm, c[2] / norm, c[3] / norm);
  }
  return pose;
}

// ---------------------------------------------------------------------------------------------
// Writing.

// A vector (fixed or run-time size) as an array of its coefficients.
template <class Derived>
nlohmann::json vec_json(const Eigen::MatrixBase<Derived>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(v[i]);
  return a;
}

// A finite number, or null where there is none (an unbounded clearance, an unconverged distance).
inline nlohmann::json finite_or_null(double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }

inline nlohmann::json quat_json(const Quat& q) { return nlohmann::json::array({q.w(), q.x(), q.y(), q.z()}); }
// A pose as json_pose reads it.
inline nlohmann::json pose_json(const Pose& p) {
  return {{"position", vec_json(p.position)}, {"quaternion", quat_json(p.rotation)}};
}

}  // namespace distlab::server
