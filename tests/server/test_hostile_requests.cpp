// The hostile-request corpus against the real server (hostile_cases.hpp): after every case the
// server must still answer, with no crash, hang, NaN/inf, 5xx or wrong class of answer. Four
// groups with a server each, so that ctest can run them side by side.
#include "server/hostile_cases.hpp"

namespace distlab::test::hostile {
namespace {

// Heavy requests stop at the request time limit (408), which keeps the suite bounded. The domains'
// limit leaves room for a first robot request, which loads the Panda's meshes: 14.3 s under ASan
// at load 4 (0.07 s once loaded), where 10 s answered 408 to a valid request.
const std::vector<std::string> kServerOptions = {"--max-request-seconds", "30"};
// WebSocket buckets refill at 1 message per second here (the default is 50), so that
// ws/rate_1000_messages empties its bucket however slowly a loaded, sanitized server reads the
// burst: at 50/s a server taking 20 ms per message never ran out of tokens (seen once under ASan).
// Every other case sends far fewer than the burst (100) on its own socket.
const std::vector<std::string> kProtocolOptions = {"--max-request-seconds", "10", "--ws-rate", "1"};

TEST(Hostile, Protocol) {
  std::vector<Case> cases;
  framing_cases(cases);
  json_cases(cases);
  static_cases(cases);
  session_cases(cases);
  ws_cases(cases);
  Runner runner(kProtocolOptions, standard_setup);
  runner.run_all(cases);
  runner.report("HTTP framing, JSON text, static paths, sessions, WebSocket");
}

TEST(Hostile, Domains) {
  std::vector<Case> cases;
  gap_cases(cases);
  levelset_cases(cases);
  kelvin_cases(cases);
  cbf_cases(cases);
  robot_cases(cases);
  Runner runner(kServerOptions, standard_setup);
  runner.run_all(cases);
  runner.report("GAP, level sets, Kelvin, CBF, robot domain values");
}

// Uploads at a triangle limit of 200k (the default is 2M): the cases one over it stay a few MB,
// which a sanitized server reads in seconds; the refusal is the same code at any limit.
const std::vector<std::string> kUploadOptions = {"--max-request-seconds", "30", "--limit", "max_upload_triangles=200000"};

TEST(Hostile, Uploads) {
  std::vector<Case> cases;
  upload_cases(cases);
  Runner runner(kUploadOptions, standard_setup);
  runner.run_all(cases);
  runner.report("uploads (STL, OBJ, PLY, OFF, GLB)");
}

// The scene items and recordings at small limits (hostile_cases.hpp, scene::k*): the cases one over
// a limit stay a few kB.
TEST(Hostile, Scene) {
  std::vector<Case> cases;
  scene_cases(cases);
  const auto limit = [](const std::string& name, std::size_t v) { return name + "=" + std::to_string(v); };
  Runner runner({"--max-request-seconds", "30", "--limit", limit("max_scene_items", scene::kItems), "--limit",
                 limit("max_scene_vertices", scene::kVertices), "--limit", limit("max_scene_bytes", scene::kBytes), "--limit",
                 limit("max_record_frames", scene::kRecordFrames), "--limit", limit("max_record_bytes", scene::kRecordBytes)},
                scene::setup);
  runner.run_all(cases);
  runner.report("scene items (msgpack frames), poses, recordings");
}

}  // namespace
}  // namespace distlab::test::hostile
