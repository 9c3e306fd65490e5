// `distlab kelvin`: prepare an object, set σ, answer queries and write iso-surfaces, from one
// JSON request on stdin (schema in distlab/server/kelvin_json.hpp). Exit codes as `distlab gap`:
// 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal error; errors go to stdout as
// JSON and one line to stderr. --progress prints stage progress lines on stderr.
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace {

using nlohmann::json;
namespace server = distlab::server;

std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

int run_kelvin(const std::vector<std::string>& args, std::istream& in, std::ostream& out, std::ostream& err) {
  bool pretty = false, show_progress = false;
  for (const std::string& a : args) {
    if (a == "--pretty") pretty = true;
    else if (a == "--progress") show_progress = true;
    else if (a == "--help" || a == "-h") {
      out << "usage: distlab kelvin [--pretty] [--progress] < request.json\n"
             "request  {\"mesh\": {\"path\": FILE} | {\"asset\": NAME}, \"lx\": m, \"center\"?: [x,y,z],\n"
             "          \"cache\"?: DIR, \"sigma\"?: {\"constant\", \"per_vertex\", \"axis\", \"brushes\"},\n"
             "          \"query\"?: [[x,y,z], ...], \"isosurfaces\"?: {\"levels\", \"format\", \"path\"},\n"
             "          \"feature_angle\"?: deg (60; 180 = no edge protection), \"max_vertices\"?: n (1000000)}\n"
             "response {\"stats\": {...}, \"query\": {\"h\", \"gradient\", \"inside\"}, \"isosurfaces\"?: [...],\n"
             "          \"warnings\"?: [...]}\n"
             "limits   meshing never hangs: more than max_vertices vertices (estimated or reached) or too many\n"
             "         refinement steps fail with an \"lx\" error; edge protection that does not converge\n"
             "         (features thinner than the elements) is dropped, with a warning.\n";
      return 0;
    } else {
      err << "distlab kelvin: unknown option '" << a << "' (see distlab kelvin --help)\n";
      return 2;
    }
  }
  auto emit = [&](const json& j) {
    out << j.dump(pretty ? 2 : -1, ' ', false, json::error_handler_t::replace) << '\n';
    out.flush();
  };
  try {
    std::string text;
    char buf[1 << 16];
    while (text.size() <= server::kMaxRequestBytes && in.read(buf, sizeof buf).gcount() > 0)
      text.append(buf, static_cast<std::size_t>(in.gcount()));
    const json request = server::parse_json_text(text);
    distlab::kelvin::Progress progress;
    if (show_progress)
      progress.report = [&err](const std::string& stage, double f) {
        err << "progress " << stage << " " << static_cast<int>(100 * f) << "%\n";
      };
    emit(server::run_kelvin_request(request, progress));
    return 0;
  } catch (const server::JsonSyntaxError& e) {
    json body = server::error_json("parse_error", e.what());
    body["error"]["byte"] = e.byte();
    emit(body);
    err << "distlab kelvin: malformed JSON: " << one_line(e.what()) << "\n";
    return 65;
  } catch (const distlab::InvalidInput& e) {
    emit(server::error_json(e));
    err << "distlab kelvin: invalid input" << (e.field().empty() ? "" : " at " + e.field()) << ": "
        << one_line(e.what()) << "\n";
    return 2;
  } catch (const std::exception& e) {
    emit(server::error_json("internal_error", e.what()));
    err << "distlab kelvin: internal error: " << one_line(e.what()) << "\n";
    return 70;
  }
}

const distlab::app::RegisterCommand kRegister(
    "kelvin", {"semantics-aware distance (Kelvin transformation): JSON on stdin, JSON on stdout", run_kelvin});

}  // namespace
