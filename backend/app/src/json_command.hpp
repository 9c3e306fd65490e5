#pragma once
// The shared shape of the JSON subcommands (gap, kelvin, cbf): one request on stdin, the response
// on stdout. Exit codes: 0 ok, 2 invalid input or usage, 65 malformed JSON, 70 internal error;
// on any error the JSON error body goes to stdout (scripts always get JSON) and one line to stderr.
#include <functional>
#include <iosfwd>
#include <set>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace distlab::app {

struct JsonCommandSpec {
  std::string name;                      // e.g. "gap"
  std::string help;                      // printed by --help
  std::vector<std::string> extra_flags;  // boolean flags besides --pretty, e.g. "--progress"
};

using JsonHandler =
    std::function<nlohmann::json(const nlohmann::json& request, const std::set<std::string>& flags)>;

int run_json_command(const JsonCommandSpec& spec, const std::vector<std::string>& args,
                     std::istream& in, std::ostream& out, std::ostream& err,
                     const JsonHandler& handler);

}  // namespace distlab::app
