// `distlab cache ls | verify | gc`: the field store (kelvin/store.hpp) that `distlab serve`,
// `distlab kelvin` ("cache") and Python's cache_dir= share. A table, or the same JSON as
// distlab.cache in Python (--json). Exit codes: 0 ok, 1 verify found bad entries, 2 bad usage
// (the message names the option).
#include <chrono>
#include <cmath>
#include <cstdint>
#include <ctime>
#include <iomanip>
#include <ostream>
#include <sstream>
#include <string>
#include <vector>

#include "command.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace {

namespace server = distlab::server;
using nlohmann::json;

const char* const kHelp =
    "usage: distlab cache ls|verify|gc [--dir DIR] [--json [--pretty]] [options]\n"
    "  ls       the entries (most recently used first, with the inputs they were prepared from),\n"
    "           the preparations in progress (their leases) and writers' temporaries\n"
    "  verify   reads every entry whole and checks its MAC, format and name; --fix removes the bad\n"
    "           ones. Exit 1 if any was bad.\n"
    "  gc       evicts the least recently used entries until they take at most --budget BYTES, and\n"
    "           removes what processes that died left (temporaries, locks)\n"
    "options\n"
    "  --dir DIR             the store (default: $XDG_CACHE_HOME/distlab or ~/.cache/distlab, as\n"
    "                        distlab serve's --cache-dir)\n"
    "  --json                JSON on stdout instead of a table (--pretty: indented)\n"
    "  --fix                 verify: remove the bad entries\n"
    "  --budget BYTES        gc: bytes the entries may take (an integer, or with K, M, G or T: powers\n"
    "                        of 1024, e.g. 20G); without it gc evicts nothing\n"
    "  --keep-recent SECONDS gc: spare entries used this recently (default 60: a reader on another\n"
    "                        machine may hold one)\n";

struct Usage {
  std::string option, message;
};

// The number v starts with; *used: its characters (0: none).
double leading_number(const std::string& v, std::size_t* used) {
  try {
    return std::stod(v, used);
  } catch (const std::exception&) {
    *used = 0;
    return -1;
  }
}

std::uint64_t parse_bytes(const std::string& v) {
  std::size_t used = 0;
  const double x = leading_number(v, &used);
  double unit = 1;
  if (used > 0 && used + 1 == v.size()) {
    const std::string units = "KMGT";
    const auto k = units.find(static_cast<char>(std::toupper(static_cast<unsigned char>(v.back()))));
    if (k != std::string::npos) {
      unit = std::pow(1024.0, static_cast<double>(k + 1));
      ++used;
    }
  }
  const double bytes = x * unit;
  if (used == 0 || used != v.size() || !(bytes >= 1 && bytes <= 1e18) || bytes != std::floor(bytes))
    throw Usage{"--budget", "'" + v + "' is not a byte count (an integer of at least 1, or with K, M, G or T, e.g. 20G)"};
  return static_cast<std::uint64_t>(bytes);
}

double parse_seconds(const std::string& v) {
  std::size_t used = 0;
  const double x = leading_number(v, &used);
  if (used == 0 || used != v.size() || !(x >= 0 && x <= 1e9))
    throw Usage{"--keep-recent", "'" + v + "' is not a number of seconds (0 to 1e9)"};
  return x;
}

std::string human_bytes(double b) {
  static const char* const kUnits[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  int u = 0;
  while (b >= 1024 && u < 4) {
    b /= 1024;
    ++u;
  }
  std::ostringstream o;
  o << std::fixed << std::setprecision(u == 0 ? 0 : 1) << b << " " << kUnits[u];
  return o.str();
}

std::string local_time(double unix_seconds) {
  const auto t = static_cast<std::time_t>(unix_seconds);
  std::tm tm{};
  localtime_r(&t, &tm);
  std::ostringstream o;
  o << std::put_time(&tm, "%Y-%m-%d %H:%M:%S");
  return o.str();
}

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

void ls_table(const json& j, std::ostream& out) {
  // SURFACE is the input surface (vertices/faces), FIELD the prepared tet mesh's vertices.
  out << std::left << std::setw(18) << "NAME" << std::setw(12) << "SIZE" << std::setw(21) << "LAST USED" << std::setw(9) << "LX"
      << std::setw(16) << "SURFACE V/F" << std::setw(13) << "FIELD VERTS"
      << "FORMAT\n";
  for (const json& e : j["entries"]) {
    const bool current = e.value("current", false);
    out << std::setw(18) << e["name"].get<std::string>().substr(0, 16) << std::setw(12) << human_bytes(e["bytes"].get<double>())
        << std::setw(21) << local_time(e["last_used"].get<double>());
    if (current) {
      std::ostringstream lx;
      lx << e["lx"].get<double>();
      const std::string surface = std::to_string(e["surface_vertices"].get<long>()) + "/" + std::to_string(e["surface_faces"].get<long>());
      out << std::setw(9) << lx.str() << std::setw(16) << surface << std::setw(13) << e["n_verts"].get<long>();
    } else {
      out << std::setw(38) << "";
    }
    // ls reads headers only: a damaged body shows as current until verify reads it whole.
    out << (current ? "current" : e.value("readable", false) ? "old: " + e.value("format", std::string())
                                                             : std::string("unreadable"))
        << "\n";
  }
  out << j["entries"].size() << " entries, " << human_bytes(j["bytes"].get<double>()) << "\n";
  const double now = unix_now();
  for (const json& l : j["leases"])
    out << "preparing " << l["name"].get<std::string>().substr(0, 16) << " on " << l["host"].get<std::string>() << " pid "
        << l["pid"].get<long>() << ": " << l["state"].get<std::string>() << ", renewed "
        << std::lround(std::max(0.0, now - l["renewed"].get<double>())) << " s ago, lease " << l["lease_seconds"].get<double>() << " s\n";
  if (!j["temporaries"].empty()) out << j["temporaries"].size() << " temporaries (writes in progress, or left by a crash: gc removes those)\n";
}

void verify_table(const json& j, std::ostream& out) {
  for (const json& e : j["entries"])
    if (e["status"] != "ok")
      out << e["name"].get<std::string>() << "  " << e["status"].get<std::string>() << (e["removed"].get<bool>() ? "  removed" : "") << "\n";
  out << j["ok"].get<long>() << " ok, " << j["bad"].get<long>() << " bad";
  if (j["removed"].get<long>() > 0) out << ", " << j["removed"].get<long>() << " removed";
  out << "\n";
}

void gc_table(const json& j, std::ostream& out) {
  for (const json& n : j["evicted"]) out << "evicted " << n.get<std::string>() << "\n";
  for (const json& n : j["removed"]) out << "removed " << n.get<std::string>() << "\n";
  out << human_bytes(j["bytes_before"].get<double>()) << " -> " << human_bytes(j["bytes_after"].get<double>());
  if (!j["budget"].is_null()) out << " (budget " << human_bytes(j["budget"].get<double>()) << ")";
  if (j["kept_recent"].get<long>() > 0) out << "; " << j["kept_recent"].get<long>() << " over the budget kept as recently used";
  out << "\n";
}

int run_cache(const std::vector<std::string>& args, std::istream&, std::ostream& out, std::ostream& err) {
  const std::string me = "distlab cache";
  if (!args.empty() && (args[0] == "--help" || args[0] == "-h")) {
    out << kHelp;
    return 0;
  }
  std::string sub, dir = server::default_cache_dir();
  bool as_json = false, pretty = false, fix = false;
  std::optional<std::uint64_t> budget;
  double keep_recent = distlab::kelvin::kDefaultKeepRecentSeconds;
  try {
    if (args.empty()) throw Usage{"", "a subcommand is required: ls, verify or gc"};
    sub = args[0];
    if (sub != "ls" && sub != "verify" && sub != "gc") throw Usage{"", "unknown subcommand '" + sub + "' (ls, verify or gc)"};
    for (std::size_t i = 1; i < args.size(); ++i) {
      const std::string& a = args[i];
      auto value = [&]() -> const std::string& {
        if (i + 1 >= args.size()) throw Usage{a, "needs a value"};
        return args[++i];
      };
      if (a == "--help" || a == "-h") {
        out << kHelp;
        return 0;
      }
      if (a == "--json") as_json = true;
      else if (a == "--pretty") pretty = as_json = true;
      else if (a == "--dir") dir = value();
      else if (a == "--fix" && sub == "verify") fix = true;
      else if (a == "--budget" && sub == "gc") budget = parse_bytes(value());
      else if (a == "--keep-recent" && sub == "gc") keep_recent = parse_seconds(value());
      else throw Usage{a, "unknown option for " + sub};
    }
    if (dir.empty()) throw Usage{"--dir", "no default cache directory ($XDG_CACHE_HOME and $HOME are unset): give --dir"};
  } catch (const Usage& u) {
    err << me << (sub.empty() || u.option.empty() ? "" : " " + sub) << ": " << (u.option.empty() ? "" : u.option + ": ") << u.message
        << " (see " << me << " --help)\n";
    return 2;
  }
  try {
    json j;
    int code = 0;
    if (sub == "ls") {
      j = server::cache_ls_json(dir);
    } else if (sub == "verify") {
      j = server::cache_verify_json(dir, fix);
      code = j["bad"].get<long>() > 0 ? 1 : 0;
    } else {
      distlab::kelvin::FieldStore store{dir, budget.value_or(0)};
      store.keep_recent_seconds = keep_recent;
      j = server::cache_gc_json(store);
    }
    if (as_json) {
      out << j.dump(pretty ? 2 : -1, ' ', false, json::error_handler_t::replace) << "\n";
    } else if (sub == "ls") {
      ls_table(j, out);
    } else if (sub == "verify") {
      verify_table(j, out);
    } else {
      gc_table(j, out);
    }
    return code;
  } catch (const distlab::InvalidInput& e) {  // the directory
    err << me << " " << sub << ": --" << e.field() << ": " << e.what() << "\n";
    return 2;
  }
}

const distlab::app::RegisterCommand kRegister(
    "cache", {"the field store of prepared Kelvin fields: ls, verify, gc (see distlab cache --help)", run_cache});

}  // namespace
