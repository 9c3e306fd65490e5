// The field store shared by processes (issue 35 item 2, store.hpp): two processes preparing one
// field make one preparation and both get it; a writer killed mid-write leaves no readable entry
// and the next preparation succeeds; leases are renewed, taken over when their holder is gone or
// has expired, by one waiter; a temporary is never read as an entry; verify names bad entries;
// the budget evicts the least recently used. The processes are this test program run again
// (KelvinStoreChild.Run) with the role in its environment.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "child_test.hpp"
#include "distlab/kelvin/digest.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/store.hpp"
#include "distlab/mesh/primitives.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

// A small field: a level-3 icosphere at a coarse l_x prepares in well under a second.
const mesh::SurfaceMesh& small_surface() {
  static const mesh::SurfaceMesh s = mesh::icosphere(0.5, 3);
  return s;
}
PrepareOptions small_options(double lx) {
  PrepareOptions o;
  o.lx = lx;
  o.centre = Vec3(0.1, -0.05, 0.04);
  return o;
}
const std::vector<Vec3> kPoints = {{0.9, 0.1, 0.2}, {-0.7, 0.6, 0.1}, {0.2, -0.3, 1.4}, {2.0, 1.0, -1.0}};

std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(dir)) out.push_back(e.path().filename().string());
  std::sort(out.begin(), out.end());
  return out;
}
std::vector<fs::path> entries_in(const fs::path& dir) {
  std::vector<fs::path> out;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().extension() == ".kelvin") out.push_back(e.path());
  std::sort(out.begin(), out.end());
  return out;
}
std::string read_file(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}
void write_file(const fs::path& p, const std::string& bytes) { std::ofstream(p, std::ios::binary | std::ios::trunc) << bytes; }

// h at kPoints as exact hex floats: equal strings are equal fields.
std::string fingerprint(Field& f) {
  SigmaSpec sigma;
  sigma.constant = 0.2;
  f.set_sigma(sigma);
  std::string out;
  char buf[64];
  for (const Vec3& x : kPoints) {
    std::snprintf(buf, sizeof buf, "%a ", f.query(x).h);
    out += buf;
  }
  return out;
}

// Sets the file's mtime (the store's "last used") to `seconds` ago.
void used_ago(const fs::path& p, double seconds) {
  struct timespec t[2];
  ::clock_gettime(CLOCK_REALTIME, &t[0]);
  t[0].tv_sec -= static_cast<time_t>(seconds);
  t[1] = t[0];
  ASSERT_EQ(::utimensat(AT_FDCWD, p.c_str(), t, 0), 0) << p;
}

std::string env(const char* name) {
  const char* v = std::getenv(name);
  return v ? v : "";
}

// ---- The other process ----

struct ChildResult {
  int status = -1;  // exit code, or 128 + signal
  std::map<std::string, std::string> values;
};

ChildResult wait_child(pid_t pid, const fs::path& out) {
  ChildResult r;
  r.status = wait_test(pid);
  std::istringstream in(read_file(out));
  std::string line;
  while (std::getline(in, line)) {
    const auto space = line.find(' ');
    if (space != std::string::npos) r.values[line.substr(0, space)] = line.substr(space + 1);
  }
  return r;
}

// Starts processes preparing the small field in `dir`, at once: each says it is ready and waits
// for the go. vars: per process, its role's settings (see KelvinStoreChild.Run).
std::vector<ChildResult> run_children(const fs::path& dir, const std::vector<std::map<std::string, std::string>>& roles) {
  const fs::path go = dir.parent_path() / (dir.filename().string() + ".go");
  fs::remove(go);
  std::vector<pid_t> pids;
  std::vector<fs::path> outs;
  for (std::size_t i = 0; i < roles.size(); ++i) {
    outs.push_back(dir.parent_path() / (dir.filename().string() + ".out" + std::to_string(i)));
    fs::remove(outs.back());
    std::map<std::string, std::string> vars = roles[i];
    vars["DISTLAB_STORE_DIR"] = dir.string();
    vars["DISTLAB_STORE_OUT"] = outs.back().string();
    vars["DISTLAB_STORE_GO"] = go.string();
    pids.push_back(spawn_test("KelvinStoreChild.Run", vars));
  }
  for (const fs::path& out : outs)
    for (int i = 0; i < 6000 && !fs::exists(out.string() + ".ready"); ++i) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  write_file(go, "go");
  std::vector<ChildResult> results;
  for (std::size_t i = 0; i < pids.size(); ++i) {
    results.push_back(wait_child(pids[i], outs[i]));
    fs::remove(outs[i]);
    fs::remove(outs[i].string() + ".ready");
  }
  fs::remove(go);
  return results;
}

}  // namespace

// One process of the tests below (skipped unless started by them). DISTLAB_STORE_CHILD:
// "prepare": prepares the small field (lx DISTLAB_STORE_LX, lease DISTLAB_STORE_LEASE) and, if it
// prepares, sleeps DISTLAB_STORE_HOLD seconds at its first meshing report (so that the other
// process certainly finds it preparing); "kill": prepares and kills itself with SIGKILL halfway
// through writing the entry.
// The entries' MAC: RFC 4231's test cases 1 and 2, whole and in uneven pieces (as an entry is
// written), and a key longer than the hash's block (case 6).
TEST(KelvinStore, HmacSha256MatchesRfc4231) {
  const auto hex = [](const Digest& d) {
    std::string out;
    for (unsigned char c : d) out += "0123456789abcdef"[c >> 4], out += "0123456789abcdef"[c & 15];
    return out;
  };
  const std::string key1(20, '\x0b'), key6(131, '\xaa');
  const std::string data6 = "Test Using Larger Than Block-Size Key - Hash Key First";
  EXPECT_EQ(hex(hmac_sha256(key1, "Hi There")), "b0344c61d8db38535ca8afceaf0bf12b881dc200c9833da726e9376c2e32cff7");
  EXPECT_EQ(hex(hmac_sha256(key6, data6)), "60e431591ee0b67f0d8a26aacbf5b77f8e0bc6213728c5140546040f0ee37f54");
  const std::string data2 = "what do ya want for nothing?";
  HmacSha256 pieces("Jefe");
  for (size_t at = 0, n = 1; at < data2.size(); at += n, n = 2 * n + 1)
    pieces.add(data2.data() + at, std::min(n, data2.size() - at));
  EXPECT_EQ(hex(pieces.digest()), "5bdcc146bf60754e6a042426089575c75a003f089d2739839dec58b964ec3843");
}

TEST(KelvinStoreChild, Run) {
  const std::string role = env("DISTLAB_STORE_CHILD");
  if (role.empty()) GTEST_SKIP() << "run by the store tests";
  const std::string out = env("DISTLAB_STORE_OUT");
  write_file(out + ".ready", "");
  while (!fs::exists(env("DISTLAB_STORE_GO"))) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  FieldStore store{env("DISTLAB_STORE_DIR")};
  if (!env("DISTLAB_STORE_LEASE").empty()) store.lease_seconds = std::stod(env("DISTLAB_STORE_LEASE"));
  const double hold = env("DISTLAB_STORE_HOLD").empty() ? 0 : std::stod(env("DISTLAB_STORE_HOLD"));
  int waits = 0;
  bool held = false;
  Progress progress;
  progress.report = [&](const std::string& stage, double f) {
    if (stage == "wait") ++waits;
    if (stage == "mesh" && !held) {
      held = true;
      std::this_thread::sleep_for(std::chrono::duration<double>(hold));
    }
    if (role == "kill" && stage == "cache" && f > 0.5 && f < 0.9) ::raise(SIGKILL);
  };
  bool hit = false;
  Field f = Field::prepare_cached(small_surface(), small_options(std::stod(env("DISTLAB_STORE_LX"))), store, progress, &hit);
  std::ofstream o(out);
  o << "hit " << hit << "\nwaits " << waits << "\nt_wait " << f.stats().t_wait << "\nn_verts " << f.stats().n_verts
    << "\nh " << fingerprint(f) << "\n";
}

// Two processes prepare the same field at once: one prepares (holding the lease, renewed every
// lease / 4 while it sleeps 4 leases in its meshing), the other waits and loads that entry; the
// fields are the same bit for bit.
TEST(KelvinStore, TwoProcessesPrepareOneFieldOnce) {
  const test::TempDir folder("distlab_store_two");
  const fs::path dir = folder.path();
  const std::map<std::string, std::string> role = {
      {"DISTLAB_STORE_CHILD", "prepare"}, {"DISTLAB_STORE_LX", "0.3"}, {"DISTLAB_STORE_LEASE", "0.4"}, {"DISTLAB_STORE_HOLD", "1.6"}};
  const std::vector<ChildResult> r = run_children(dir, {role, role});
  ASSERT_EQ(r.size(), 2u);
  for (const ChildResult& c : r) ASSERT_EQ(c.status, 0);
  // Exactly one preparation; the other waited (it saw the lease) and loaded the entry.
  EXPECT_EQ((r[0].values.at("hit") == "0") + (r[1].values.at("hit") == "0"), 1);
  const ChildResult& waiter = r[0].values.at("hit") == "1" ? r[0] : r[1];
  EXPECT_GE(std::stoi(waiter.values.at("waits")), 1);
  // Not taken over: the holder renewed its 0.4 s lease through its 1.6 s in meshing.
  EXPECT_GT(std::stod(waiter.values.at("t_wait")), 0.4);
  EXPECT_EQ(r[0].values.at("h"), r[1].values.at("h"));
  EXPECT_EQ(r[0].values.at("n_verts"), r[1].values.at("n_verts"));
  // One entry, the key, nothing else: the lease and the temporary are gone.
  EXPECT_EQ(names_in(dir).size(), 2u) << ::testing::PrintToString(names_in(dir));
  EXPECT_EQ(entries_in(dir).size(), 1u);
}

// A writer killed (SIGKILL) halfway through writing its entry leaves its lease and a partial
// temporary, and no entry anyone reads. The next preparation takes the dead holder's lease over
// at once (its process is gone) and succeeds; gc removes the leftovers.
TEST(KelvinStore, WriterKilledMidWriteLeavesNoEntry) {
  const test::TempDir folder("distlab_store_killed");
  const fs::path dir = folder.path();
  const std::vector<ChildResult> r = run_children(dir, {{{"DISTLAB_STORE_CHILD", "kill"}, {"DISTLAB_STORE_LX", "0.12"}}});
  ASSERT_EQ(r.at(0).status, 128 + SIGKILL);
  EXPECT_TRUE(entries_in(dir).empty()) << ::testing::PrintToString(names_in(dir));
  const StoreListing before = list_store(dir.string());
  EXPECT_TRUE(before.entries.empty());
  ASSERT_EQ(before.temporaries.size(), 1u);
  EXPECT_NE(before.temporaries[0].find(".kelvin.tmp."), std::string::npos) << before.temporaries[0];
  ASSERT_EQ(before.leases.size(), 1u);
  EXPECT_EQ(before.leases[0].state, "dead");

  // A lease of an hour: only the holder's death lets this preparation through (a watchdog fails
  // the test instead of waiting that hour).
  FieldStore store{dir.string()};
  store.lease_seconds = 3600;
  std::atomic<bool> cancel{false};
  Progress progress;
  progress.cancel = &cancel;
  std::thread watchdog([&] {
    for (int i = 0; i < 600 && !cancel; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
    cancel = true;
  });
  bool hit = true;
  bool cancelled = false;
  try {
    Field f = Field::prepare_cached(small_surface(), small_options(0.12), store, progress, &hit);
    EXPECT_FALSE(hit);
  } catch (const Cancelled&) {
    cancelled = true;
  }
  cancel = true;
  watchdog.join();
  ASSERT_FALSE(cancelled) << "the dead writer's lease was not taken over";
  EXPECT_TRUE(list_store(dir.string()).leases.empty());
  const GcReport gc = gc_store(store);
  EXPECT_EQ(gc.removed, before.temporaries);
  EXPECT_TRUE(list_store(dir.string()).temporaries.empty());
  Field again = Field::prepare_cached(small_surface(), small_options(0.12), store, {}, &hit);
  EXPECT_TRUE(hit);
}

// A lock from another machine (its process cannot be checked) that nobody renews is taken over
// once the waiter has seen it unchanged for its lease, and not before; two waiters take it over
// once between them (it is renamed aside, so only one of them gets it).
TEST(KelvinStore, ExpiredLeaseIsTakenOverByOneWaiter) {
  const test::TempDir folder("distlab_store_expired");
  const fs::path dir = folder.path();
  // The entry's name is its content key: found by preparing it in another store.
  const test::TempDir scratch_folder("distlab_store_expired_scratch");
  const fs::path scratch = scratch_folder.path();
  Field::prepare_cached(small_surface(), small_options(0.3), scratch.string());
  const std::string name = entries_in(scratch).at(0).filename().string();
  const std::string lock =
      "distlab-lease 1\nhost elsewhere\nnode another-boot:1\npid 1\npid_start 1\ntoken 0\nlease 0.5\nstarted 0\nrenewed 0\n";
  write_file(dir / (name + ".lock"), lock);
  EXPECT_EQ(list_store(dir.string()).leases.at(0).state, "held");  // by its mtime: written just now
  used_ago(dir / (name + ".lock"), 10);
  EXPECT_EQ(list_store(dir.string()).leases.at(0).state, "expired");

  bool hit = true;
  Field f = Field::prepare_cached(small_surface(), small_options(0.3), dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  EXPECT_GE(f.stats().t_wait, 0.5);
  EXPECT_FALSE(fs::exists(dir / (name + ".lock")));

  // Again with two processes waiting on it: one takes over and prepares, the other loads.
  fs::remove(dir / name);
  write_file(dir / (name + ".lock"), lock);
  const std::map<std::string, std::string> role = {
      {"DISTLAB_STORE_CHILD", "prepare"}, {"DISTLAB_STORE_LX", "0.3"}, {"DISTLAB_STORE_HOLD", "1.0"}};
  const std::vector<ChildResult> r = run_children(dir, {role, role});
  ASSERT_EQ(r.at(0).status, 0);
  ASSERT_EQ(r.at(1).status, 0);
  EXPECT_EQ((r[0].values.at("hit") == "0") + (r[1].values.at("hit") == "0"), 1);
  EXPECT_EQ(r[0].values.at("h"), r[1].values.at("h"));
  EXPECT_EQ(r[0].values.at("h"), fingerprint(f));
}

// Only a complete entry under its own name is ever read: a complete copy under a temporary's
// name is not an entry, a truncated entry is refused by its framing and a changed one by its MAC
// (rebuilt either way); verify names each kind and --fix removes them.
TEST(KelvinStore, HalfWrittenAndDamagedEntriesAreNeverServed) {
  const test::TempDir folder("distlab_store_damaged");
  const fs::path dir = folder.path();
  bool hit = true;
  Field a = Field::prepare_cached(small_surface(), small_options(0.3), dir.string(), {}, &hit);
  const std::string truth = fingerprint(a);
  const fs::path entry = entries_in(dir).at(0);
  const std::string bytes = read_file(entry);
  // The complete file, but under a temporary's name only: a miss, prepared again.
  fs::rename(entry, entry.string() + ".tmp.0badc0de.1.0");
  Field b = Field::prepare_cached(small_surface(), small_options(0.3), dir.string(), {}, &hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(fingerprint(b), truth);
  fs::remove(entry.string() + ".tmp.0badc0de.1.0");

  const auto status = [&](bool fix) {
    std::map<std::string, std::string> out;
    for (const VerifiedEntry& v : verify_store(dir.string(), fix)) out[v.name] = v.status + (v.removed ? " removed" : "");
    return out;
  };
  const std::string name = entry.stem().string();
  EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, "ok"}}));
  for (const std::string& damage : std::vector<std::string>{"truncated", "bad_mac"}) {
    write_file(
        entry, damage == "truncated" ? bytes.substr(0, bytes.size() / 2) : [&] {
          std::string flipped = bytes;
          flipped[flipped.size() / 3] ^= 0x10;
          return flipped;
        }());
    EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, damage}}));
    Field c = Field::prepare_cached(small_surface(), small_options(0.3), dir.string(), {}, &hit);
    EXPECT_FALSE(hit) << damage;
    EXPECT_EQ(fingerprint(c), truth) << damage;
    EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, "ok"}})) << damage;  // rebuilt in its place
  }
  // An intact entry under another name, one of an older format (MAC'd with the key), and all of
  // them once the key is gone.
  const std::string other = std::string(64, 'a');
  write_file(dir / (other + ".kelvin"), bytes);
  std::string old = bytes;
  const std::size_t digit = old.find("-v", 8) + 2;
  old[digit] = old[digit] == '9' ? '8' : '9';
  const std::string key = read_file(dir / "cache.key");
  const Digest mac = hmac_sha256(key, std::string_view(old).substr(8, old.size() - 8 - 32));
  old.replace(old.size() - 32, 32, reinterpret_cast<const char*>(mac.data()), 32);
  const std::string older = std::string(64, 'b');
  write_file(dir / (older + ".kelvin"), old);
  EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, "ok"}, {other, "wrong_name"}, {older, "old_format"}}));
  const StoreListing listing = list_store(dir.string());
  ASSERT_EQ(listing.entries.size(), 3u);
  for (const StoreEntry& e : listing.entries) {
    EXPECT_TRUE(e.readable) << e.name;
    EXPECT_EQ(e.current, e.name != older) << e.name;
    if (e.current) {
      EXPECT_EQ(e.lx, 0.3);
      EXPECT_EQ(e.surface_faces, small_surface().faces.rows());
      EXPECT_EQ(e.n_verts, a.stats().n_verts);
      EXPECT_EQ(e.n_tets, a.stats().n_tets);
    }
  }
  EXPECT_EQ(status(true), (std::map<std::string, std::string>{{name, "ok"}, {other, "wrong_name removed"}, {older, "old_format removed"}}));
  EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, "ok"}}));
  fs::remove(dir / "cache.key");
  EXPECT_EQ(status(false), (std::map<std::string, std::string>{{name, "no_key"}}));
}

// The budget evicts the least recently used entries (a load counts as a use), spares entries
// used within keep_recent_seconds, and runs after each write of a store with a budget.
TEST(KelvinStore, BudgetEvictsLeastRecentlyUsed) {
  const test::TempDir folder("distlab_store_budget");
  const fs::path dir = folder.path();
  std::map<double, fs::path> entry;  // by lx
  std::map<double, std::uint64_t> size;
  for (const double lx : {0.3, 0.35, 0.4}) {
    const auto before = entries_in(dir);
    Field::prepare_cached(small_surface(), small_options(lx), dir.string());
    for (const fs::path& p : entries_in(dir))
      if (std::find(before.begin(), before.end(), p) == before.end()) entry[lx] = p;
    size[lx] = fs::file_size(entry[lx]);
  }
  // Used 300, 200 and 100 s ago, in lx order.
  used_ago(entry[0.3], 300);
  used_ago(entry[0.35], 200);
  used_ago(entry[0.4], 100);
  FieldStore store{dir.string()};
  store.budget_bytes = size[0.35] + size[0.4];
  GcReport gc = gc_store(store);
  EXPECT_EQ(gc.evicted, std::vector<std::string>{entry[0.3].stem().string()});
  EXPECT_EQ(gc.bytes_before, size[0.3] + size[0.35] + size[0.4]);
  EXPECT_EQ(gc.bytes_after, size[0.35] + size[0.4]);
  // Loading the older one makes the other the least recently used.
  bool hit = false;
  Field::prepare_cached(small_surface(), small_options(0.35), dir.string(), {}, &hit);
  EXPECT_TRUE(hit);
  store.budget_bytes = size[0.35];
  gc = gc_store(store);
  EXPECT_EQ(gc.evicted, std::vector<std::string>{entry[0.4].stem().string()});
  // Over any budget, an entry just used is spared (a reader may hold it), unless told otherwise.
  store.budget_bytes = 1;
  gc = gc_store(store);
  EXPECT_TRUE(gc.evicted.empty());
  EXPECT_EQ(gc.kept_recent, 1u);
  store.keep_recent_seconds = 0;
  gc = gc_store(store);
  EXPECT_EQ(gc.evicted, std::vector<std::string>{entry[0.35].stem().string()});
  EXPECT_TRUE(entries_in(dir).empty());

  // A store with a budget evicts when it writes: two old entries out, the new one in.
  Field::prepare_cached(small_surface(), small_options(0.3), dir.string());
  Field::prepare_cached(small_surface(), small_options(0.35), dir.string());
  used_ago(entry[0.3], 300);
  used_ago(entry[0.35], 200);
  store.budget_bytes = size[0.4];
  store.keep_recent_seconds = 60;
  Field::prepare_cached(small_surface(), small_options(0.4), store, {}, &hit);
  EXPECT_FALSE(hit);
  EXPECT_EQ(entries_in(dir), std::vector<fs::path>{entry[0.4]});
}
