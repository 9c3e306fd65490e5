// `distlab serve`: the HTTP + WebSocket service on one port (REST under /api, the WebSocket at
// /ws, the front end's static files from --web). Stops gracefully on SIGINT/SIGTERM: the
// listener closes, running jobs are cancelled, WebSocket clients get a close frame.
#include <cmath>
#include <csignal>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>
#include <type_traits>
#include <vector>

#include "command.hpp"
#include "distlab/server/data_dirs.hpp"
#include "distlab/server/modules.hpp"
#include "distlab/server/server.hpp"

namespace {

namespace fs = std::filesystem;
namespace server = distlab::server;

const char* kUsage =
    "usage: distlab serve [options]\n"
    "  --host ADDR              address to bind (default 127.0.0.1)\n"
    "  --port N                 port (default 8080; 0 picks a free one, printed on stdout)\n"
    "  --assets DIR             built-in meshes (default: $DISTLAB_ASSETS, ./assets, or assets or\n"
    "                           share/distlab/assets beside the binary or above it; a given DIR must exist)\n"
    "  --cache-dir DIR          prepared Kelvin objects (default: $XDG_CACHE_HOME/distlab or ~/.cache/distlab)\n"
    "  --web DIR                static front end (default: $DISTLAB_WEB, ./web/dist, or web/dist or\n"
    "                           share/distlab/web beside the binary or above it; a given DIR must exist)\n"
    "  --threads N              compute and job threads each (default: all cores)\n"
    "limits (defaults in GET /api/limits):\n"
    "  --max-body-bytes N  --max-upload-bytes N  --max-upload-triangles N  --min-lx X\n"
    "  --max-vertices N  --max-sessions N  --max-objects-per-session N  --max-jobs-per-session N\n"
    "  --max-jobs N  --max-job-seconds X  --max-request-seconds X  --max-ws-message-bytes N\n"
    "  --ws-rate X  --ws-burst X  --import-memory-bytes N  --import-seconds X\n"
    "  --limit NAME=VALUE       any limit of GET /api/limits by its name (e.g. max_connections=64)\n";

int run_serve(const std::vector<std::string>& args, std::istream&, std::ostream& out, std::ostream& err) {
  std::string host = "127.0.0.1";
  unsigned long port = 8080;
  server::ServiceConfig config;
  std::string assets_dir, web_dir;  // as given; found by find_data_dir below
  config.cache_dir = server::default_cache_dir();
  config.mesh_worker = "/proc/self/exe";  // this binary's mesh-domain (isolated_mesher.hpp)
  server::Limits& lim = config.limits;
  try {
    for (std::size_t i = 0; i < args.size(); ++i) {
      const std::string& a = args[i];
      if (a == "--help" || a == "-h") {
        out << kUsage;
        return 0;
      }
      if (i + 1 >= args.size()) {
        err << "distlab serve: " << a << " needs a value (or is unknown)\n"
            << kUsage;
        return 2;
      }
      const std::string& v = args[++i];
      auto count = [&] { return static_cast<std::size_t>(std::stoull(v)); };
      if (a == "--host") host = v;
      else if (a == "--port") port = std::stoul(v);
      else if (a == "--assets") assets_dir = v;
      else if (a == "--cache-dir") config.cache_dir = v;
      else if (a == "--web") web_dir = v;
      else if (a == "--threads") config.compute_threads = config.job_threads = static_cast<unsigned>(std::stoul(v));
      else if (a == "--max-body-bytes") lim.max_body_bytes = count();
      else if (a == "--max-upload-bytes") lim.max_upload_bytes = count();
      else if (a == "--max-upload-triangles") lim.max_upload_triangles = count();
      else if (a == "--min-lx") lim.min_lx = std::stod(v);
      else if (a == "--max-vertices") lim.max_vertex_estimate = count();
      else if (a == "--max-sessions") lim.max_sessions = count();
      else if (a == "--max-objects-per-session") lim.max_objects_per_session = count();
      else if (a == "--max-jobs-per-session") lim.max_jobs_per_session = count();
      else if (a == "--max-jobs") lim.max_jobs_total = count();
      else if (a == "--max-job-seconds") lim.max_job_seconds = std::stod(v);
      else if (a == "--max-request-seconds") lim.max_request_seconds = std::stod(v);
      else if (a == "--max-ws-message-bytes") lim.max_ws_message_bytes = count();
      else if (a == "--ws-rate") lim.ws_messages_per_second = std::stod(v);
      else if (a == "--ws-burst") lim.ws_burst = std::stod(v);
      else if (a == "--import-memory-bytes") lim.import_memory_bytes = count();
      else if (a == "--import-seconds") lim.import_seconds = std::stod(v);
      else if (a == "--limit") {
        const std::size_t eq = v.find('=');
        bool found = false;
        server::for_each_limit(lim, [&](const char* name, auto& field) {
          if (eq == std::string::npos || v.compare(0, eq, name) != 0 || eq != std::strlen(name)) return;
          std::size_t used = 0;
          const std::string value = v.substr(eq + 1);
          const double x = std::stod(value, &used);
          if (used != value.size() || !(x >= 0 && x <= 1e15)) throw std::invalid_argument(name);
          field = static_cast<std::remove_reference_t<decltype(field)>>(x);
          found = true;
        });
        if (!found) {
          err << "distlab serve: --limit " << v << ": no such limit (see GET /api/limits)\n";
          return 2;
        }
      } else {
        err << "distlab serve: unknown option '" << a << "'\n"
            << kUsage;
        return 2;
      }
    }
  } catch (const std::exception&) {
    err << "distlab serve: bad option value\n"
        << kUsage;
    return 2;
  }
  try {
    config.assets_dir = server::find_data_dir("--assets", "DISTLAB_ASSETS", "assets", "assets", assets_dir);
    config.web_dir = server::find_data_dir("--web", "DISTLAB_WEB", "web/dist", "web", web_dir);
  } catch (const std::exception& e) {
    err << "distlab serve: " << e.what() << "\n";
    return 2;
  }
  if (port > 65535) {
    err << "distlab serve: --port must be 0..65535\n";
    return 2;
  }
  if (lim.max_upload_bytes < lim.max_body_bytes) lim.max_upload_bytes = lim.max_body_bytes;
  std::signal(SIGPIPE, SIG_IGN);  // a peer closing mid-write is an error code, not a signal
  try {
    server::Service service(config);
    server::add_standard_modules(service);
    server::HttpServer http(service, host, static_cast<unsigned short>(port));
    out << "distlab serve: listening on http://" << host << ":" << http.port() << "/ (assets " << config.assets_dir
        << ", cache " << (config.cache_dir.empty() ? "temporary" : config.cache_dir) << ", web " << config.web_dir << ")"
        << std::endl;
    http.run(true);
    out << "distlab serve: stopped" << std::endl;
  } catch (const std::exception& e) {
    err << "distlab serve: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

const distlab::app::RegisterCommand registered(
    "serve", {"run the HTTP + WebSocket service (REST under /api, WebSocket /ws, front end)", run_serve});

}  // namespace
