// libFuzzer: the GAP request codec, JSON text -> parse_json_text -> shapes and params ->
// run_gap_request (the body of POST /api/gap/distance and of `distlab gap`). A refusal
// (InvalidInput, JsonSyntaxError) is fine; a crash, a sanitizer report, a timeout, or an answer
// with a null or non-finite number where the schema promises one is a finding.
#include <cmath>
#include <cstdint>
#include <exception>
#include <string_view>

#include "distlab/server/gap_json.hpp"

namespace {

bool finite_numbers(const nlohmann::json& j) {
  if (j.is_number_float()) return std::isfinite(j.get<double>());
  if (j.is_structured())
    for (const auto& v : j)
      if (!finite_numbers(v)) return false;
  return true;
}

bool has_null(const nlohmann::json& j, const char* key) {
  if (j.is_object()) {
    if (j.contains(key) && j[key].is_null()) return true;
    for (const auto& v : j)
      if (has_null(v, key)) return true;
  } else if (j.is_array()) {
    for (const auto& v : j)
      if (has_null(v, key)) return true;
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace distlab::server;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  nlohmann::json request;
  try {
    request = parse_json_text(text);
  } catch (const std::exception&) {
    return 0;
  }
  try {
    // The solver stops after its iteration limit; keep each input's work small.
    if (request.is_object() && request.contains("params") && request["params"].is_object()) {
      auto& p = request["params"];
      if (p.contains("max_iter") && p["max_iter"].is_number() && p["max_iter"].get<double>() > 1000) p["max_iter"] = 1000;
    }
    if (request.is_object() && request.contains("pairs") && request["pairs"].is_array() && request["pairs"].size() > 8) return 0;
    const nlohmann::json out = run_gap_request(request);
    if (!finite_numbers(out)) __builtin_trap();
    for (const char* key : {"lambda", "distance"})
      if (has_null(out, key)) __builtin_trap();
  } catch (const std::exception&) {
  }
  return 0;
}
