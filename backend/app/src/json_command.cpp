#include "json_command.hpp"

#include <algorithm>
#include <istream>
#include <ostream>
#include <stdexcept>

#include "distlab/geometry/error.hpp"
#include "distlab/server/gap_json.hpp"

namespace distlab::app {
namespace {

using nlohmann::json;

constexpr int kExitOk = 0;
constexpr int kExitInvalid = 2;
constexpr int kExitParse = 65;     // EX_DATAERR
constexpr int kExitInternal = 70;  // EX_SOFTWARE

// One line for stderr: messages may quote user input.
std::string one_line(std::string s) {
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

int run_json_command(const JsonCommandSpec& spec, const std::vector<std::string>& args,
                     std::istream& in, std::ostream& out, std::ostream& err,
                     const JsonHandler& handler) {
  const std::string me = "distlab " + spec.name;
  bool pretty = false;
  std::set<std::string> flags;
  for (const std::string& a : args) {
    if (a == "--pretty") {
      pretty = true;
    } else if (a == "--help" || a == "-h") {
      out << spec.help;
      return kExitOk;
    } else if (std::find(spec.extra_flags.begin(), spec.extra_flags.end(), a) !=
               spec.extra_flags.end()) {
      flags.insert(a);
    } else {
      err << me << ": unknown option '" << a << "' (see " << me << " --help)\n";
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
    while (text.size() <= server::Limits{}.max_body_bytes && in.read(buf, sizeof buf).gcount() > 0)
      text.append(buf, static_cast<std::size_t>(in.gcount()));
    if (in.bad()) throw std::runtime_error("cannot read stdin");
    emit(handler(server::parse_json_text(text), flags));
    return kExitOk;
  } catch (const server::JsonSyntaxError& e) {
    json body = server::error_json("parse_error", e.what());
    body["error"]["byte"] = e.byte();
    emit(body);
    err << me << ": malformed JSON: " << one_line(e.what()) << "\n";
    return kExitParse;
  } catch (const InvalidInput& e) {
    emit(server::error_json(e));
    err << me << ": invalid input" << (e.field().empty() ? "" : " at " + e.field()) << ": "
        << one_line(e.what()) << "\n";
    return kExitInvalid;
  } catch (const std::exception& e) {
    emit(server::error_json("internal_error", e.what()));
    err << me << ": internal error: " << one_line(e.what()) << "\n";
    return kExitInternal;
  }
}

}  // namespace distlab::app
