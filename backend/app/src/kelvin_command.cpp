// `distlab kelvin`: prepare an object, set σ, answer queries and write iso-surfaces, from one
// JSON request on stdin (schema in distlab/server/kelvin_json.hpp). Exit codes as `distlab gap`:
// 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal error; errors go to stdout as
// JSON and one line to stderr. --progress prints stage progress lines on stderr.
#include <ostream>
#include <set>
#include <string>
#include <vector>

#include "command.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/kelvin_json.hpp"
#include "json_command.hpp"

namespace {

namespace server = distlab::server;

const char* const kHelp =
    "usage: distlab kelvin [--pretty] [--progress] < request.json\n"
    "request  {\"mesh\": {\"path\": FILE} | {\"asset\": NAME}, \"lx\": m, \"center\"?: [x,y,z],\n"
    "          \"grading\"?: g in [0, 1] (0: eq. 23; > 0: graded sizing, fewer vertices; absent: chosen,\n"
    "                     stats.grading),\n"
    "          \"cache\"?: DIR (the field store: see distlab cache --help), \"cache_budget\"?: bytes,\n"
    "          \"sigma\"?: {\"constant\", \"per_vertex\", \"axis\", \"brushes\"},\n"
    "          \"query\"?: [[x,y,z], ...], \"isosurfaces\"?: {\"levels\", \"format\", \"path\"} (one level: path;\n"
    "                     several: path's stem + \"_<i>\" + its extension, i the level's index in levels),\n"
    "          \"feature_angle\"?: deg (60; sharp edges: eq. 23 protects them, the graded sizing\n"
    "                     refines near them; 180: none), \"max_vertices\"?: n (1000000),\n"
    "          \"repair\"?: \"none\" | \"fix\" | \"wrap\", \"repair_options\"?: {\"max_hole_edges\"} | {\"alpha\", \"offset\"}}\n"
    "response {\"stats\": {...}, \"query\": {\"h\", \"gradient\", \"inside\"}, \"isosurfaces\"?: [...],\n"
    "          \"repair\"?: {fix: \"steps\"; wrap: \"alpha\", \"offset\", \"hausdorff\"},\n"
    "          \"warnings\"?: [...]}\n"
    "limits   meshing never hangs: more than max_vertices vertices (estimated or reached) or too many\n"
    "         refinement steps fail with an \"lx\" error; eq. 23's edge protection that does not converge\n"
    "         (features thinner than the elements) is dropped, with a warning.\n";

int run_kelvin(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
               std::ostream& err) {
  return distlab::app::run_json_command(
      {"kelvin", kHelp, {"--progress"}}, args, in, out, err,
      [&err](const nlohmann::json& request, const std::set<std::string>& flags) {
        distlab::kelvin::Progress progress;
        if (flags.count("--progress"))
          progress.report = [&err](const std::string& stage, double f) {
            err << "progress " << stage << " " << static_cast<int>(100 * f) << "%\n";
          };
        return server::run_kelvin_request(request, progress, "/proc/self/exe");  // mesh_threads > 1 in a child
      });
}

const distlab::app::RegisterCommand kRegister(
    "kelvin", {"semantics-aware distance (Kelvin transformation): JSON on stdin, JSON on stdout", run_kelvin});

}  // namespace
