// libFuzzer: the CBF rollout request codec, JSON text -> parse_json_text -> parse_cbf_request
// (inline scenarios: obstacles with GAP shapes, target, settings, margins, params). A refusal is
// fine; a crash, a sanitizer report or a timeout is a finding. Named scenarios read files and are
// left out (the path check is a string rule, tested by the server suite), and so are scenarios
// with Kelvin fields, which read meshes and prepare fields (tests/cbf/test_wrench_grasp.cpp and
// the server's field tests cover their codec).
#include <cstdint>
#include <exception>
#include <string_view>

#include "distlab/server/cbf_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace distlab::server;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  try {
    const nlohmann::json request = parse_json_text(text);
    if (request.is_object() && request.contains("scenario") &&
        (request["scenario"].is_string() || (request["scenario"].is_object() && request["scenario"].contains("fields"))))
      return 0;
    const CbfRequest parsed = parse_cbf_request(request);
    (void)parsed.scenario.steps();
  } catch (const std::exception&) {
  }
  return 0;
}
