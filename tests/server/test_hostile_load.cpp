// Hostile conditions beyond single requests: a bounded load run with per-session isolation
// checks, corrupted and forged cache files between restarts, a session flood from one address,
// and file-descriptor exhaustion by idle connections.
#include <algorithm>
#include <atomic>
#include <mutex>

#include "server/hostile_cases.hpp"

namespace distlab::test::hostile {
namespace {

// ---------------------------------------------------------------------------------------------
// Load: a few clients, each with its own session, objects, uploads and jobs, edit and query at
// once; every one of them also tries the others' ids, which must answer 404.

TEST(HostileLoad, SessionsStayIsolatedUnderLoad) {
  Runner runner({}, [](Ctx& ctx, ServerProcess&) { ctx.session = make_session(ctx); });
  Ctx& base = runner.ctx();
  constexpr int kClients = 4, kRounds = 25;
  struct Client {
    Ctx ctx;
    std::string object, upload, rollout;
  };
  std::vector<Client> clients(kClients);
  for (auto& c : clients) c.ctx.port = base.port;
  std::mutex mutex;
  std::vector<std::string> failures;
  std::atomic<int> requests{0};
  auto fail = [&](const std::string& what) {
    std::lock_guard lock(mutex);
    failures.push_back(what);
  };
  auto checked = [&](Ctx& ctx, const std::string& m, const std::string& t, const std::string& body, const std::string& s,
                     int want, const std::string& what) {
    ++requests;
    const Reply r = call(ctx, m, t, body, s);
    if (r.status >= 500 || r.status == 0) fail(what + ": status " + std::to_string(r.status) + " " + r.body.substr(0, 120));
    else if (want != 0 && r.status != want) fail(what + ": status " + std::to_string(r.status) + ", expected " + std::to_string(want));
    if (r.content_type.find("json") != std::string::npos && has_nonfinite_token(r.body)) fail(what + ": NaN/Infinity");
    return r;
  };
  // Phase 1: each client makes its resources (in parallel).
  {
    std::vector<std::thread> ts;
    for (int i = 0; i < kClients; ++i)
      ts.emplace_back([&, i] {
        Client& c = clients[i];
        c.ctx.session = make_session(c.ctx);
        c.object = ready_cube(c.ctx, c.ctx.session);
        const json up = json::parse(checked(c.ctx, "POST", "/api/kelvin/uploads?format=obj", kTetraObj, c.ctx.session, 201, "upload").body,
                                    nullptr, false);
        c.upload = up.value("upload", "");
        c.rollout = short_rollout(c.ctx, c.ctx.session);
      });
    for (auto& t : ts) t.join();
  }
  for (const auto& c : clients) ASSERT_FALSE(c.object.empty() || c.upload.empty() || c.rollout.empty());
  // Phase 2: rounds of own edits and queries, and attempts on the next client's ids.
  {
    std::vector<std::thread> ts;
    for (int i = 0; i < kClients; ++i)
      ts.emplace_back([&, i] {
        Client& c = clients[i];
        const Client& o = clients[(i + 1) % kClients];
        const std::string s = c.ctx.session;
        for (int k = 0; k < kRounds; ++k) {
          const double value = 0.01 * (i + 1) + 0.001 * k;
          checked(c.ctx, "PUT", "/api/kelvin/objects/" + c.object + "/sigma", json{{"constant", value}}.dump(), s, 200, "own sigma");
          const json q = json::parse(checked(c.ctx, "POST", "/api/kelvin/objects/" + c.object + "/query",
                                             json{{"points", {{1.2, 0.1, 0}}}}.dump(), s, 200, "own query")
                                         .body,
                                     nullptr, false);
          if (!q.is_object() || null_in(q, {"h"})) fail("own query: h null outside the cube");
          const json sg = json::parse(checked(c.ctx, "GET", "/api/kelvin/objects/" + c.object + "/sigma", "", s, 200, "own sigma read").body,
                                      nullptr, false);
          if (!sg.is_object() || sg["sigma"].value("constant", -1.0) != value)
            fail("client " + std::to_string(i) + " reads a σ it did not set: " + sg.dump().substr(0, 120));
          // The other session's ids.
          checked(c.ctx, "GET", "/api/kelvin/objects/" + o.object, "", s, 404, "other's object");
          checked(c.ctx, "PUT", "/api/kelvin/objects/" + o.object + "/sigma", json{{"constant", 9}}.dump(), s, 404, "other's sigma");
          checked(c.ctx, "POST", "/api/kelvin/objects/" + o.object + "/query", json{{"points", {{1, 0, 0}}}}.dump(), s, 404, "other's query");
          checked(c.ctx, "GET", "/api/kelvin/objects/" + o.object + "/surface", "", s, 404, "other's surface");
          checked(c.ctx, "DELETE", "/api/kelvin/objects/" + o.object, "", s, 404, "delete other's object");
          checked(c.ctx, "POST", "/api/kelvin/objects", json{{"upload", o.upload}, {"lx", 0.2}}.dump(), s, 404, "other's upload");
          checked(c.ctx, "GET", "/api/jobs/" + o.rollout, "", s, 404, "other's job");
          checked(c.ctx, "POST", "/api/jobs/" + o.rollout + "/cancel", "", s, 404, "cancel other's job");
          checked(c.ctx, "GET", "/api/cbf/rollouts/" + o.rollout + "/frames", "", s, 404, "other's rollout frames");
          const json list = json::parse(checked(c.ctx, "GET", "/api/kelvin/objects", "", s, 200, "own list").body, nullptr, false);
          if (!list.is_object() || list["objects"].size() != 1 || list["objects"][0].value("id", "") != c.object)
            fail("client " + std::to_string(i) + " lists objects that are not its own: " + list.dump().substr(0, 160));
          checked(c.ctx, "GET", "/api/kelvin/objects/" + c.object + "/isosurface?level=0.3", "", s, 200, "own isosurface");
        }
      });
    for (auto& t : ts) t.join();
  }
  // Nothing of one session changed another's: each still has its object and its last σ.
  for (int i = 0; i < kClients; ++i) {
    const json sg = json::parse(call(clients[i].ctx, "GET", "/api/kelvin/objects/" + clients[i].object + "/sigma", "", clients[i].ctx.session).body,
                                nullptr, false);
    EXPECT_DOUBLE_EQ(sg["sigma"].value("constant", -1.0), 0.01 * (i + 1) + 0.001 * (kRounds - 1));
  }
  EXPECT_EQ(runner.health_status(), 200);
  std::printf("\n=== hostile load: %d clients, %d requests, %zu failures ===\n", kClients, requests.load(), failures.size());
  for (const auto& f : failures) std::printf("  LOAD: %s\n", f.c_str());
  EXPECT_TRUE(failures.empty());
  EXPECT_EQ(runner.server().stop(), 0);
}

// ---------------------------------------------------------------------------------------------
// Cache files corrupted (or forged) between restarts: the object is rebuilt and answers the true h.

std::uint64_t fnv64(const std::string& s) {  // the checksum the cache used when this was written
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  return h;
}

std::vector<fs::path> cache_files(const std::string& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::recursive_directory_iterator(dir))
    if (e.is_regular_file() && e.path().filename().string().rfind("upload-", 0) != 0) out.push_back(e.path());
  return out;
}

std::string read_all(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::ostringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

void write_all(const fs::path& p, const std::string& s) { std::ofstream(p, std::ios::binary | std::ios::trunc) << s; }

// Today's layout (kelvin/src/cache.cpp): u64 size, payload, u64 FNV-1a of the payload; the payload
// is the format tag, the key (u64 32 + 32 hex digits), the surface (u64 n + n doubles, u64 n + n
// int32), 9 doubles of inputs, then the tet mesh's points (u64 n + n doubles). Returns the file
// with every point scaled by 1.5 and a matching checksum ("" if the layout is not found).
std::string forged(const std::string& file) {
  if (file.size() < 64) return file;
  std::string payload = file.substr(8, file.size() - 16);
  auto u64 = [&](std::size_t at) {
    std::uint64_t v = 0;
    if (at + 8 <= payload.size()) std::memcpy(&v, payload.data() + at, 8);
    return v;
  };
  std::size_t at = std::string::npos;
  for (std::size_t i = 0; i + 40 <= payload.size() && i < 256; ++i)
    if (u64(i) == 32 && std::all_of(payload.begin() + i + 8, payload.begin() + i + 40, [](char c) { return std::isxdigit(static_cast<unsigned char>(c)); })) {
      at = i + 40;
      break;
    }
  if (at == std::string::npos) return file;
  at += 8 + 8 * u64(at);  // surface vertices
  at += 8 + 4 * u64(at);  // surface faces
  at += 9 * 8;            // inputs and params
  const std::uint64_t n = u64(at);
  at += 8;
  if (at + 8 * n > payload.size()) return file;
  for (std::uint64_t i = 0; i < n; ++i) {
    double x;
    std::memcpy(&x, payload.data() + at + 8 * i, 8);
    x *= 1.5;
    std::memcpy(payload.data() + at + 8 * i, &x, 8);
  }
  const std::uint64_t size = payload.size(), sum = fnv64(payload);
  return std::string(reinterpret_cast<const char*>(&size), 8) + payload + std::string(reinterpret_cast<const char*>(&sum), 8);
}

TEST(HostileCache, CorruptedOrForgedCacheFilesAreRebuilt) {
  const TempDir cache_dir("distlab-hostile-cachefiles");
  const std::string& cache = cache_dir.path();
  const json points = {{1.2, 0.1, 0.0}, {0.3, 0.9, -0.4}, {0.0, 0.0, 1.5}};
  json truth;
  {
    ServerProcess server({}, cache);
    Ctx ctx;
    ctx.port = server.port();
    const std::string s = make_session(ctx);
    const std::string id = ready_cube(ctx, s);
    call(ctx, "PUT", "/api/kelvin/objects/" + id + "/sigma", json{{"constant", 0.5}}.dump(), s);
    truth = json::parse(call(ctx, "POST", "/api/kelvin/objects/" + id + "/query", json{{"points", points}}.dump(), s).body)["h"];
    ASSERT_EQ(server.stop(), 0);
  }
  const auto files = cache_files(cache);
  ASSERT_FALSE(files.empty());
  std::map<fs::path, std::string> pristine;
  for (const auto& f : files) pristine[f] = read_all(f);
  using Corrupt = std::function<void(const fs::path&, const std::string&)>;
  const std::vector<std::tuple<std::string, Corrupt, std::string>> variants = {
      {"truncated", [](const fs::path& p, const std::string& s) { write_all(p, s.substr(0, s.size() / 2)); }, ""},
      {"empty", [](const fs::path& p, const std::string&) { write_all(p, ""); }, ""},
      {"byte_flipped", [](const fs::path& p, const std::string& s) { std::string t = s; t[t.size() / 2] ^= 0x5a; write_all(p, t); }, ""},
      {"trailing_garbage", [](const fs::path& p, const std::string& s) { write_all(p, s + "garbage"); }, ""},
      {"size_field_2_40", [](const fs::path& p, const std::string& s) {
         std::string t = s;
         const std::uint64_t big = 1ull << 40;
         std::memcpy(t.data(), &big, 8);
         write_all(p, t);
       },
       ""},
      {"random_bytes", [](const fs::path& p, const std::string& s) {
         std::string t(s.size(), '\0');
         std::mt19937 g(11);
         for (auto& c : t) c = static_cast<char>(g());
         write_all(p, t);
       },
       ""},
      {"symlink_dev_zero", [](const fs::path& p, const std::string&) {
         fs::remove(p);
         fs::create_symlink("/dev/zero", p);
       },
       ""},
      // The tetrahedral mesh's points moved (x 1.5) and the (unkeyed) checksum recomputed, as
      // anyone who can write the cache directory can: only a keyed MAC tells.
      {"forged_points", [](const fs::path& p, const std::string& s) { write_all(p, forged(s)); }, "12 keyed MAC"},
  };
  std::size_t cases = 0, failures = 0;
  for (const auto& [name, corrupt, why] : variants) {
    SCOPED_TRACE(name);
    ++cases;
    for (const auto& [p, bytes] : pristine) {
      std::error_code ec;
      fs::remove(p, ec);
      write_all(p, bytes);
      corrupt(p, bytes);
    }
    ServerProcess server({}, cache);
    Ctx ctx;
    ctx.port = server.port();
    const std::string s = make_session(ctx);
    const json made = json::parse(call(ctx, "POST", "/api/kelvin/objects", json{{"asset", "cube"}, {"lx", 0.2}}.dump(), s).body, nullptr, false);
    ASSERT_TRUE(made.is_object() && made.contains("job")) << made.dump();
    const json st = wait_job(ctx, s, made["job"]["id"], 300);
    const bool alive = exchange(ctx.port, http("GET", "/api/health"), 15).size() == 1;
    EXPECT_TRUE(alive) << "the server died on a " << name << " cache file";
    EXPECT_EQ(st.value("state", ""), "succeeded") << name << ": " << st.dump();
    bool ok = alive && st.value("state", "") == "succeeded";
    if (ok) {
      const std::string id = made["object"]["id"];
      call(ctx, "PUT", "/api/kelvin/objects/" + id + "/sigma", json{{"constant", 0.5}}.dump(), s);
      const json h = json::parse(call(ctx, "POST", "/api/kelvin/objects/" + id + "/query",
                                      json{{"points", points}}.dump(), s)
                                     .body,
                                 nullptr, false)["h"];
      for (std::size_t i = 0; i < points.size(); ++i) {
        const bool same = h[i].is_number() && truth[i].is_number() && std::abs(h[i].get<double>() - truth[i].get<double>()) <= 1e-9;
        EXPECT_TRUE(same) << name << ": h = " << h[i] << " where the true value is " << truth[i] << (why.empty() ? "" : " [" + why + "]");
        ok = ok && same;
      }
    }
    if (!ok) ++failures;
    EXPECT_EQ(server.stop(), 0) << name;
  }
  std::printf("\n=== hostile cache files: %zu cases, %zu failures ===\n", cases, failures);
}

// ---------------------------------------------------------------------------------------------
// One client address cannot take every session: after a flood from 127.0.0.1, a client from
// 127.0.0.2 still gets one, and the cap is published.

TEST(HostileLimits, SessionFloodFromOneAddressLeavesOthersServed) {
  ServerProcess server({"--max-sessions", "40"});
  const int port = server.port();
  int created = 0, refused = 0, other = 0;
  for (int i = 0; i < 60; ++i) {
    const auto r = exchange(port, http("POST", "/api/session"), 15);
    const int st = r.empty() ? 0 : r.front().status;
    if (st == 201) ++created;
    else if (st == 429) ++refused;
    else ++other;
  }
  EXPECT_EQ(other, 0) << "a session request answered neither 201 nor 429";
  Socket s(port, "127.0.0.2");
  ASSERT_TRUE(s.ok()) << "cannot connect from 127.0.0.2";
  s.send(http("POST", "/api/session"));
  std::string data;
  s.read(data, Clock::now() + std::chrono::seconds(15));
  const auto replies = parse_replies(data);
  ASSERT_FALSE(replies.empty());
  EXPECT_EQ(replies.front().status, 201) << "[11 sessions per client address] after " << created << " sessions from one address, "
                                         << "another address gets: " << replies.front().body;
  const auto lr = exchange(port, http("GET", "/api/limits"), 15);
  ASSERT_FALSE(lr.empty());
  const json limits = json::parse(lr.front().body, nullptr, false);
  EXPECT_TRUE(limits.is_object() && limits.contains("max_sessions")) << "[11] max_sessions is not published in /api/limits";
  std::printf("\n=== hostile session flood: %d created, %d refused from one address ===\n", created, refused);
  EXPECT_EQ(server.stop(), 0);
}

// ---------------------------------------------------------------------------------------------
// Idle connections past the server's descriptor limit: it must not spin (EMFILE), must serve
// again once they close, and publishes its connection cap.

double cpu_seconds(pid_t pid) {
  std::ifstream f("/proc/" + std::to_string(pid) + "/stat");
  std::string line;
  std::getline(f, line);
  std::istringstream ss(line.substr(line.rfind(')') + 2));
  std::vector<std::string> fields;
  for (std::string x; ss >> x;) fields.push_back(x);
  // utime and stime are fields 14 and 15 of stat, i.e. 11 and 12 after the state.
  return (std::stod(fields.at(11)) + std::stod(fields.at(12))) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

TEST(HostileLimits, DescriptorExhaustionDoesNotSpinOrStick) {
  ServerProcess server({}, "", 96);
  const int port = server.port();
  std::vector<std::unique_ptr<Socket>> held;
  for (int i = 0; i < 150; ++i) held.push_back(std::make_unique<Socket>(port));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const double cpu0 = cpu_seconds(server.pid());
  const auto t0 = Clock::now();
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));
  const double busy = (cpu_seconds(server.pid()) - cpu0) / std::chrono::duration<double>(Clock::now() - t0).count();
  // An accept loop retrying EMFILE at once keeps a core busy; backing off leaves it nearly idle.
  EXPECT_LT(busy, 0.1) << "[10 EMFILE backoff] the server used " << busy << " CPU-seconds per second while idle connections "
                       << "exhausted its descriptors";
  held.clear();
  int health = 0;
  for (int i = 0; i < 50 && health != 200; ++i) {
    const auto r = exchange(port, http("GET", "/api/health"), 5);
    health = r.empty() ? 0 : r.front().status;
    if (health != 200) std::this_thread::sleep_for(std::chrono::milliseconds(200));
  }
  EXPECT_EQ(health, 200) << "no health answer after the idle connections closed";
  const auto r = exchange(port, http("GET", "/api/limits"), 15);
  ASSERT_FALSE(r.empty());
  EXPECT_NE(r.front().body.find("connections"), std::string::npos) << "[10] no connection cap in /api/limits";
  std::printf("\n=== hostile descriptors: %.2f CPU-s/s while exhausted ===\n", busy);
  EXPECT_EQ(server.stop(), 0);
}

}  // namespace
}  // namespace distlab::test::hostile
