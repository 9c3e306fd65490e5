// Benchmark client of `distlab serve` (loopback; start the server first):
//   distlab-bench-server [--port 8080] [--lx 0.06] [--edits 40] [--clients 50] [--seconds 30]
// 1. σ edit -> iso-surface frame received over the WebSocket, on a Kelvin field of the cube asset
//    (l_x chosen for ~25k vertices): median and p95 latency.
// 2. `clients` concurrent clients, each repeatedly querying h at 1000 points and GAP on 100 pairs
//    for `seconds`: throughput, p95 latency per request kind, error count.
#include <algorithm>
#include <atomic>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "../src/huge_page_heap.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "distlab/server/config.hpp"
#include "distlab/server/frames.hpp"
#include "distlab/server/kelvin_objects.hpp"

namespace beast = boost::beast;
namespace http = beast::http;
namespace net = boost::asio;
using tcp = net::ip::tcp;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

namespace {

std::string g_host = "127.0.0.1";
std::string g_port = "8080";

class HttpClient {
 public:
  HttpClient() : stream_(ioc_) { stream_.connect(tcp::resolver(ioc_).resolve(g_host, g_port)); }
  // Returns the status; body in *out.
  int request(http::verb verb, const std::string& target, const std::string& body, const std::string& session,
              std::string* out = nullptr) {
    http::request<http::string_body> req{verb, target, 11};
    req.set(http::field::host, g_host);
    req.set(http::field::content_type, "application/json");
    if (!session.empty()) req.set("X-Distlab-Session", session);
    req.body() = body;
    req.prepare_payload();
    http::write(stream_, req);
    beast::flat_buffer buf;
    http::response_parser<http::string_body> parser;
    parser.body_limit(1u << 30);
    http::read(stream_, buf, parser);
    if (out) *out = parser.get().body();
    return parser.get().result_int();
  }

 private:
  net::io_context ioc_;
  beast::tcp_stream stream_;
};

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(p * static_cast<double>(v.size())))];
}

std::string session_of(HttpClient& c) {
  std::string body;
  c.request(http::verb::post, "/api/session", "", "", &body);
  return json::parse(body)["session"];
}

std::string ready_object(HttpClient& c, const std::string& s, double lx, bool quiet = false) {
  std::string body;
  int st = 0;
  for (int attempt = 0; attempt < 600; ++attempt) {  // 429: the server's job limit; wait and retry
    st = c.request(http::verb::post, "/api/kelvin/objects", json{{"asset", "cube"}, {"lx", lx}}.dump(), s, &body);
    if (st != 429) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (st != 202) throw std::runtime_error("create: " + body);
  std::string id = json::parse(body)["object"]["id"];  // returned: moved, not copied
  for (int i = 0; i < 3000; ++i) {
    c.request(http::verb::get, "/api/kelvin/objects/" + id, "", s, &body);
    const json j = json::parse(body);
    if (j["state"] == "ready") {
      if (!quiet) std::printf("object ready: %ld vertices, %ld tets (cache hit: %s)\n", j["stats"]["n_verts"].get<long>(),
                              j["stats"]["n_tets"].get<long>(), j["stats"]["cache_hit"].get<bool>() ? "yes" : "no");
      return id;
    }
    if (j["state"] != "preparing") throw std::runtime_error("prepare: " + body);
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  throw std::runtime_error("prepare: timeout");
}

template <class Fn>
double median_ms(int reps, Fn&& fn) {
  std::vector<double> t;
  for (int i = 0; i < reps; ++i) {
    const auto t0 = Clock::now();
    fn(i);
    t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
  }
  return percentile(t, 0.5);
}

// Stroke i as the page paints one (default brush: radius 0.14, falloff 0.069, "towards", stamps
// r/2 apart) across a face of the unit cube: about 5% of its surface.
std::vector<distlab::kelvin::BrushSigma> stroke_stamps(int i) {
  const int face = i % 6, axis = face / 2;
  const double side = face % 2 == 0 ? 0.5 : -0.5, offset = 0.05 * (i % 5) - 0.1;
  std::vector<distlab::kelvin::BrushSigma> out;
  for (int k = 0; k < 7; ++k) {
    distlab::Vec3 c = distlab::Vec3::Zero();
    c[axis] = side;
    c[(axis + 1) % 3] = -0.21 + 0.07 * k;
    c[(axis + 2) % 3] = offset;
    out.push_back({c, 0.14, (i % 2 == 0 ? 1.0 : -0.5), 0.069, true});
  }
  return out;
}

// In-process: where the time of one σ edit goes, stage by stage (same field as the service).
int breakdown(const std::string& assets, const std::string& cache, double lx, int reps) {
  using namespace distlab;
  const mesh::SurfaceMesh surface = mesh::weld(mesh::load_mesh(assets + "/cube.stl", "asset")).surface;
  kelvin::PrepareOptions options;
  options.lx = lx;
  kelvin::Field field = kelvin::Field::prepare_cached(surface, options, cache);
  std::printf("field: %ld vertices, %ld tets\n", field.stats().n_verts, field.stats().n_tets);
  auto sigma = [](int i) {
    kelvin::SigmaSpec s;
    s.constant = 0.002 * (i + 1);  // near the service bench's σ range: a similar iso-surface
    return s;
  };
  const double t_solve_grad = median_ms(reps, [&](int i) { field.set_sigma(sigma(i), true, false); });
  const double t_solve = median_ms(reps, [&](int i) { field.set_sigma(sigma(i), false, false); });
  // Another constant by linearity (Field::set_sigma): V scaled, no solve.
  const double t_shift = median_ms(reps, [&](int i) { field.set_sigma(sigma(i + 1), false); });
  mesh::SurfaceMesh iso;
  const double t_iso = median_ms(reps, [&](int) { iso = field.isosurface(0.3); });
  std::size_t bytes = 0;
  const double t_frame = median_ms(reps, [&](int) {
    bytes = server::to_msgpack(server::mesh_frame(iso, {{"type", "isosurface"}, {"level", 0.3}})).size();
  });
  std::string digest;
  const double t_digest = median_ms(reps, [&](int) { digest = kelvin::surface_digest(iso); });
  // One edit as the server's frame loop runs it: σ → V, marching tets, frame, digest, msgpack.
  const double t_edit = median_ms(reps, [&](int i) {
    field.set_sigma(sigma(reps + i), false);
    const mesh::SurfaceMesh m = field.isosurface(0.3);
    json frame = server::mesh_frame(m, {{"type", "isosurface"}, {"level", 0.3}, {"digest", kelvin::surface_digest(m)}});
    bytes = server::to_msgpack(frame).size();
  });
  // A σ version after the first sends σ per input vertex only (the surface went out once).
  std::size_t sigma_bytes = 0;
  const double t_surface = median_ms(reps, [&](int i) {
    const auto values = kelvin::evaluate_at_vertices(sigma(i), surface.vertices);
    sigma_bytes = server::to_msgpack(server::scalars_frame(values, {{"type", "surface_sigma"}})).size();
  });
  // A brush stroke (stroke_stamps) after `before` earlier strokes, solved by linearity (the σ
  // appends brushes) against the full solve of the same σ.
  const int before = 20;
  auto stroke = [](kelvin::SigmaSpec s, int i) {
    for (const kelvin::BrushSigma& b : stroke_stamps(i)) s.brushes.push_back(b);
    return s;
  };
  kelvin::SigmaSpec painted = sigma(0);
  for (int i = 0; i < before; ++i) painted = stroke(painted, i);
  // Each stroke from the same state, by linearity and in full, alternating which goes first.
  struct Strokes {
    std::vector<double> linear, full, linear_iso, full_iso, reached, diff;
  };
  auto strokes = [&] {
    Strokes t;
    for (int i = 0; i < reps; ++i) {
      const kelvin::SigmaSpec next = stroke(painted, before + i);
      for (int side = 0; side < 2; ++side) {
        const bool linear = (side == 0) == (i % 2 == 0);
        field.set_sigma(painted, false, false);  // the state before the stroke
        const auto t0 = Clock::now();
        field.set_sigma(next, false, linear);
        const auto t1 = Clock::now();
        iso = field.isosurface(0.3);
        const auto t2 = Clock::now();
        (linear ? t.linear : t.full).push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
        (linear ? t.linear_iso : t.full_iso).push_back(std::chrono::duration<double, std::milli>(t2 - t0).count());
        if (linear) {
          t.reached.push_back(static_cast<double>(field.stats().linear_boundary) /
                              static_cast<double>(field.boundary_points().size()));
          const VecX v = field.vertex_values();
          field.set_sigma(next, false, false);
          double d = 0, scale = 0;
          for (Eigen::Index k = 0; k < v.size(); ++k)
            if (!std::isnan(v[k]))
              d = std::max(d, std::abs(v[k] - field.vertex_values()[k])), scale = std::max(scale, std::abs(v[k]));
          t.diff.push_back(d / scale);
        }
      }
    }
    return t;
  };
  const Strokes by_factor = strokes();
  // As the service holds the field: with its boundary response if the default limit allows it.
  const bool response = field.build_boundary_response(static_cast<double>(server::Limits{}.max_response_bytes) / 1e6);
  const Strokes by_response = response ? strokes() : Strokes{};
  {  // checksum of the iso-surface (orientation-sensitive), so two builds can be compared
    double sum = 0;
    for (Eigen::Index f = 0; f < iso.faces.rows(); ++f) {
      const Vec3 a = iso.vertices.row(iso.faces(f, 0)), b = iso.vertices.row(iso.faces(f, 1)), c = iso.vertices.row(iso.faces(f, 2));
      sum += (b - a).cross(c - a).dot(a) * static_cast<double>(f % 7 + 1);
    }
    std::printf("iso-surface: %ld faces, checksum %.12g\n", static_cast<long>(iso.faces.rows()), sum);
  }
  std::printf("| stage (median of %d) | ms |\n|---|---:|\n", reps);
  std::printf("| Kelvin solve (full) + vertex gradients | %.1f |\n| Kelvin solve only (full) | %.1f |\n", t_solve_grad, t_solve);
  std::printf("| another constant by linearity (V scaled) | %.2f |\n", t_shift);
  std::printf("| marching tets, level 0.3 (%ld vertices) | %.1f |\n", static_cast<long>(iso.vertices.rows()), t_iso);
  std::printf("| msgpack iso frame (%zu bytes) | %.1f |\n| σ per surface vertex frame (%zu bytes) | %.1f |\n",
              bytes, t_frame, sigma_bytes, t_surface);
  std::printf("| SHA-256 digest of the iso-surface | %.1f |\n| one edit: σ → V (another constant), marching tets, frame, digest, msgpack | %.1f |\n",
              t_digest, t_edit);
  std::printf(
      "\nA brush stroke (7 stamps, r 0.14, falloff 0.069, towards) after %d strokes (%zu brushes): boundary values "
      "reached median %.1f%%. V by linearity against the full solve of the same σ (median of %d, alternating), with "
      "the factor, then with the boundary response (%.0f MB; none if over the service's default limit)\n"
      "| σ → V | full solve ms | by linearity ms | ratio | max relative difference |\n|---|---:|---:|---:|---:|\n",
      before, painted.brushes.size() + 7, 100 * percentile(by_factor.reached, 0.5), reps, field.stats().response_mb);
  nlohmann::json out = {{"t_solve_gradients_ms", t_solve_grad}, {"t_solve_constant_ms", t_solve}, {"t_shift_constant_ms", t_shift}, {"t_isosurface_ms", t_iso}, {"t_frame_ms", t_frame}, {"t_digest_ms", t_digest}, {"t_edit_ms", t_edit}, {"repeats", reps}, {"boundary_reached", percentile(by_factor.reached, 0.5)}, {"response_mb", field.stats().response_mb}};
  auto row = [&](const char* name, const Strokes& t, const std::string& key) {
    if (t.linear.empty()) return;
    const double lin = percentile(t.linear, 0.5), full = percentile(t.full, 0.5);
    const double lin_iso = percentile(t.linear_iso, 0.5), full_iso = percentile(t.full_iso, 0.5);
    const double diff = *std::max_element(t.diff.begin(), t.diff.end());
    std::printf("| solve, %s | %.2f | %.2f | %.2f | %.1e |\n| solve + marching tets, %s | %.2f | %.2f | %.2f | |\n", name,
                full, lin, lin / full, diff, name, full_iso, lin_iso, lin_iso / full_iso);
    out[key] = {{"solve_full_ms", full}, {"solve_linear_ms", lin}, {"ratio", lin / full}, {"solve_iso_full_ms", full_iso}, {"solve_iso_linear_ms", lin_iso}, {"max_relative_difference", diff}};
  };
  row("factor", by_factor, "stroke_by_factor");
  row("response", by_response, "stroke_by_response");
  std::printf("JSON %s\n", out.dump().c_str());
  return 0;
}

}  // namespace

const char* kUsage =
    "usage: distlab-bench-server [options]   (start `distlab serve` first; loopback only)\n"
    "  --host ADDR        server address (default 127.0.0.1)\n"
    "  --port N           server port (default 8080)\n"
    "  --lx X             l_x of the cube's Kelvin field (default 0.06)\n"
    "  --edits N          σ edits timed edit -> iso-surface frame (default 40)\n"
    "  --edit KIND        constant (each edit another constant σ) or brush (one more stroke each)\n"
    "  --clients N        concurrent query clients (default 50)\n"
    "  --seconds X        length of the load phase (default 30)\n"
    "  --breakdown DIR    no server: time each stage of an edit in-process on DIR's cube asset\n"
    "  --cache-dir DIR    field cache of --breakdown (default /tmp/distlab-bench-cache)\n"
    "  --help             this text\n";

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  double lx = 0.06, seconds = 30;
  int edits = 40, clients = 50;
  bool brush_edits = false;
  std::string breakdown_assets, cache = "/tmp/distlab-bench-cache";
  static const std::vector<std::string> known = {"--port", "--host", "--lx", "--edits", "--clients", "--seconds", "--breakdown", "--cache-dir", "--edit"};
  for (int i = 1; i < argc; i += 2) {
    const std::string k = argv[i];
    if (k == "--help" || k == "-h") {
      std::fputs(kUsage, stdout);
      return 0;
    }
    if (std::find(known.begin(), known.end(), k) == known.end() || i + 1 >= argc) {
      std::fprintf(stderr, "distlab-bench-server: %s is unknown or needs a value\n%s", k.c_str(), kUsage);
      return 2;
    }
    const std::string v = argv[i + 1];
    try {
      if (k == "--port") g_port = v;
      else if (k == "--host") g_host = v;
      else if (k == "--lx") lx = std::stod(v);
      else if (k == "--edits") edits = std::clamp(std::stoi(v), 1, 10000);
      else if (k == "--clients") clients = std::clamp(std::stoi(v), 1, 500);
      else if (k == "--seconds") seconds = std::clamp(std::stod(v), 1.0, 600.0);
      else if (k == "--breakdown") breakdown_assets = v;
      else if (k == "--cache-dir") cache = v;
      else if (k == "--edit" && (v == "constant" || v == "brush")) brush_edits = v == "brush";
      else if (k == "--edit") throw std::invalid_argument(v);
    } catch (const std::exception&) {
      std::fprintf(stderr, "distlab-bench-server: %s %s: not a valid value\n", k.c_str(), v.c_str());
      return 2;
    }
  }
  if (!breakdown_assets.empty()) return breakdown(breakdown_assets, cache, lx, edits);
  try {
    // ---- 1. σ edit -> iso-surface frame.
    HttpClient c;
    const std::string s = session_of(c);
    const std::string id = ready_object(c, s, lx);
    net::io_context ioc;
    beast::websocket::stream<tcp::socket> ws(ioc);
    net::connect(ws.next_layer(), tcp::resolver(ioc).resolve(g_host, g_port));
    ws.next_layer().set_option(tcp::no_delay(true));  // as browsers do on WebSockets
    ws.handshake(g_host + ":" + g_port, "/ws?session=" + s);
    auto read_until_frame = [&](long version) {
      for (;;) {
        beast::flat_buffer buf;
        ws.read(buf);
        if (!ws.got_binary()) continue;
        json f = json::from_msgpack(beast::buffers_to_string(buf.data()));
        if (f["type"] == "isosurface" && f["sigma_version"] == version) return f;
      }
    };
    ws.write(net::buffer(json{{"type", "watch"}, {"object", id}, {"levels", {0.3}}}.dump()));
    json frame = read_until_frame(0);
    std::vector<double> lat, solve, iso, since_edit;
    json brushes = json::array();
    for (int i = 1; i <= edits; ++i) {
      const auto t0 = Clock::now();
      // A new σ every time: another constant, or one more brush stroke (the page sends every brush).
      json sigma = {{"constant", 0.0005 * i}};
      if (brush_edits) {
        for (const auto& b : stroke_stamps(i))
          brushes.push_back({{"center", {b.centre.x(), b.centre.y(), b.centre.z()}}, {"radius", b.radius}, {"value", b.value}, {"falloff", b.falloff}, {"mode", "towards"}});
        sigma = {{"constant", 0.0}, {"brushes", brushes}};
      }
      ws.write(net::buffer(json{{"type", "sigma"}, {"object", id}, {"sigma", sigma}}.dump()));
      frame = read_until_frame(i);
      lat.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      if (frame.contains("server_ms")) {
        solve.push_back(frame["server_ms"].value("solve", 0.0));
        iso.push_back(frame["server_ms"].value("isosurface", 0.0));
        since_edit.push_back(frame["server_ms"].value("since_edit", 0.0));
      }
    }
    std::printf("sigma edit (%s) -> isosurface frame (%ld iso vertices): median %.1f ms, p95 %.1f ms over %d edits\n",
                brush_edits ? "a brush stroke more" : "another constant", frame["n_vertices"].get<long>(), percentile(lat, 0.5), percentile(lat, 0.95), edits);
    std::printf(
        "  server side: Kelvin solve median %.1f ms, marching tets median %.1f ms, edit received -> frame "
        "encoded median %.1f ms, p95 %.1f ms\n",
        percentile(solve, 0.5), percentile(iso, 0.5), percentile(since_edit, 0.5), percentile(since_edit, 0.95));
    // In order, to tell a tail that grows with the edits from one that recurs.
    std::printf("  per edit, edit received -> frame encoded (solve) ms:");
    for (size_t k = 0; k < since_edit.size(); ++k) std::printf(" %.1f (%.1f)", since_edit[k], solve[k]);
    std::printf("\n");
    ws.close(beast::websocket::close_code::normal);

    // ---- 2. Concurrent clients.
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> u(-2.0, 2.0);
    json points = json::array();
    for (int i = 0; i < 1000; ++i) points.push_back({u(rng), u(rng), u(rng)});
    const std::string query_body = json{{"points", points}}.dump();
    json pairs = json::array();
    for (int i = 0; i < 100; ++i)
      pairs.push_back({{"a", {{"type", "box"}, {"size", {1, 0.5, 0.3}}}},
                       {"b", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {1.5 + 0.01 * i, u(rng) * 0.2, 0}}}}}}});
    const std::string gap_body = json{{"pairs", pairs}, {"params", {{"validate", false}}}}.dump();
    std::atomic<long> errors{0}, requests{0};
    std::mutex m;
    std::vector<double> lat_query, lat_gap;
    const auto end = Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
    std::vector<std::thread> threads;
    threads.reserve(static_cast<std::size_t>(clients));
    for (int t = 0; t < clients; ++t)
      threads.emplace_back([&] {
        std::vector<double> lq, lg;
        try {
          HttpClient hc;
          const std::string ss = session_of(hc);
          const std::string oid = ready_object(hc, ss, lx, true);  // shared preparation: instant
          while (Clock::now() < end) {
            auto t0 = Clock::now();
            if (hc.request(http::verb::post, "/api/kelvin/objects/" + oid + "/query", query_body, ss) != 200) ++errors;
            lq.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
            t0 = Clock::now();
            if (hc.request(http::verb::post, "/api/gap/distance", gap_body, "") != 200) ++errors;
            lg.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
            requests += 2;
          }
        } catch (const std::exception& e) {
          ++errors;
          std::fprintf(stderr, "client: %s\n", e.what());
        }
        std::lock_guard lock(m);
        lat_query.insert(lat_query.end(), lq.begin(), lq.end());
        lat_gap.insert(lat_gap.end(), lg.begin(), lg.end());
      });
    for (auto& th : threads) th.join();
    std::printf("%d clients, %.0f s: %ld requests (%.1f/s; %.0f h-queries/s, %.0f GAP pairs/s), errors %ld\n", clients,
                seconds, requests.load(), requests.load() / seconds, lat_query.size() * 1000.0 / seconds,
                lat_gap.size() * 100.0 / seconds, errors.load());
    std::printf("  query h at 1000 points: median %.1f ms, p95 %.1f ms\n", percentile(lat_query, 0.5), percentile(lat_query, 0.95));
    std::printf("  GAP on 100 pairs:       median %.1f ms, p95 %.1f ms\n", percentile(lat_gap, 0.5), percentile(lat_gap, 0.95));
    return errors.load() == 0 ? 0 : 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "distlab-bench-server: %s\n", e.what());
    return 1;
  }
}
