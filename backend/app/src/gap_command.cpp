// `distlab gap`: one GAP request (JSON) on stdin, the response (JSON) on stdout.
// Exit codes: 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal error; on any error
// the JSON error body goes to stdout (so scripts always get JSON) and one line to stderr.
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command.hpp"
#include "distlab/server/gap_json.hpp"

namespace {

using nlohmann::json;
namespace server = distlab::server;

constexpr int kExitOk = 0;
constexpr int kExitInvalid = 2;
constexpr int kExitParse = 65;     // EX_DATAERR
constexpr int kExitInternal = 70;  // EX_SOFTWARE

constexpr const char* kHelp = R"(usage: distlab gap [--pretty] < request.json

Reads one JSON request on stdin, writes the JSON response on stdout (compact; --pretty indents).

request   {"a": SHAPE, "b": SHAPE, "params": PARAMS}
          {"pairs": [{"a": SHAPE, "b": SHAPE}, ...], "params": PARAMS}   (at most 10000 pairs)
          an optional top-level "comment" string is ignored
SHAPE     {"type": "polytope", "A": [[x,y,z], ...], "b": [...]}         (at most 1000 rows)
          {"type": "box", "size": [x, y, z]}                            (full edge lengths)
          {"type": "sphere", "radius": r}
          {"type": "cylinder", "radius": r, "height": l}                (full length along z)
          {"type": "capsule", "radius": r, "height": l}                 (core segment along z)
          {"type": "convex_hull", "points": [[x,y,z], ...]}             (at most 100000 points)
          optional: "pose": {"position": [x,y,z], "quaternion": [w,x,y,z]} (normalised),
                    "weights": [...] (polytope, box, convex_hull: one per half-space),
                    "rho": {"center": [x,y,z], "radius": R} (shape frame, must cover the shape)
PARAMS    h (0.1), k (2), eps (0.01), sigma (0.98995), weight_margin (0.01), tol (1e-10),
          max_iter (0 = solver default), solver ("newton" | "fixed_point"), gradient (true),
          validate (true: check Property 2 on every shape and refuse if it fails)
response  "lambda", "distance", "witness_a", "witness_b", "iterations", "converged", "overlap",
          "euclidean": {"distance", "witness_a", "witness_b"[, "gradient_a", "gradient_b"]},
          with gradient: "gradient_a", "gradient_b" (d distance / d (v, w), world frame),
          with validate: "validation": {"a": {"ok", "max_eigenvalue", "samples"}, "b": ...};
          a batch answers {"results": [...]}
errors    {"error": {"code", "message", "field"}}; field is a path such as "pairs[2].b.size[1]"
exit      0 ok, 2 invalid input ("invalid_input"), 65 malformed JSON ("parse_error"),
          70 internal error ("internal_error")
)";

// One line for stderr: messages may quote user input.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

int run_gap(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
            std::ostream& err) {
  bool pretty = false;
  for (const std::string& a : args) {
    if (a == "--pretty") {
      pretty = true;
    } else if (a == "--help" || a == "-h") {
      out << kHelp;
      return kExitOk;
    } else {
      err << "distlab gap: unknown option '" << a << "' (see distlab gap --help)\n";
      return kExitInvalid;
    }
  }
  auto emit = [&](const json& j) {
    // replace: never throw on a stray byte in an echoed name; numbers print shortest round-trip.
    out << j.dump(pretty ? 2 : -1, ' ', false, json::error_handler_t::replace) << '\n';
    out.flush();
  };

  try {
    // Read at most one byte past the limit, so a huge stream is refused without buffering it.
    std::string text;
    char buf[1 << 16];
    while (text.size() <= server::kMaxRequestBytes && in.read(buf, sizeof buf).gcount() > 0)
      text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (in.bad()) throw std::runtime_error("cannot read stdin");
    const json request = server::parse_json_text(text);
    emit(server::run_gap_request(request));
    return kExitOk;
  } catch (const server::JsonSyntaxError& e) {
    json body = server::error_json("parse_error", e.what());
    body["error"]["byte"] = e.byte();
    emit(body);
    err << "distlab gap: malformed JSON: " << one_line(e.what()) << "\n";
    return kExitParse;
  } catch (const distlab::InvalidInput& e) {
    emit(server::error_json(e));
    err << "distlab gap: invalid input" << (e.field().empty() ? "" : " at " + e.field()) << ": "
        << one_line(e.what()) << "\n";
    return kExitInvalid;
  } catch (const std::exception& e) {
    emit(server::error_json("internal_error", e.what()));
    err << "distlab gap: internal error: " << one_line(e.what()) << "\n";
    return kExitInternal;
  }
}

const distlab::app::RegisterCommand kRegister(
    "gap", {"GAP differentiable distance of shape pairs: JSON on stdin, JSON on stdout", run_gap});

}  // namespace
