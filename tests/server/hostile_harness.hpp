#pragma once
// The hostile-input runner: a case is a request (raw bytes, so framing can be broken too) and the
// class of answer it must get. After every case the server must still answer /api/health; a dead
// server is a crash, a silent one a hang (per-case timeouts); any 5xx, any NaN/Infinity token or
// non-finite float32 in an answer, and an answer of the wrong class are failures. A crashed or
// hung server is restarted so that the remaining cases still run; the counts are printed at the end.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <sys/resource.h>
#include <sys/socket.h>

#include <cmath>
#include <cstring>
#include <map>
#include <memory>
#include <set>
#include <sstream>

#include "server/server_fixture.hpp"

namespace distlab::test::hostile {

using Clock = std::chrono::steady_clock;

// ---------------------------------------------------------------------------------------------
// Raw HTTP with deadlines.

class Socket {
 public:
  // source: the local address to bind (127.0.0.x), "" for any.
  explicit Socket(int port, const std::string& source = "") {
    fd_ = ::socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
    if (fd_ < 0) return;
    if (!source.empty()) {
      sockaddr_in local{};
      local.sin_family = AF_INET;
      ::inet_pton(AF_INET, source.c_str(), &local.sin_addr);
      if (::bind(fd_, reinterpret_cast<sockaddr*>(&local), sizeof local) != 0) {
        close();
        return;
      }
    }
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<uint16_t>(port));
    ::inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
      close();
      return;
    }
    int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
  }
  ~Socket() { close(); }
  Socket(const Socket&) = delete;
  Socket& operator=(const Socket&) = delete;
  bool ok() const { return fd_ >= 0; }
  void close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  // Sends everything (false if the peer closed: a server may refuse before the body is sent).
  bool send(std::string_view data) {
    while (!data.empty() && fd_ >= 0) {
      const ssize_t n = ::send(fd_, data.data(), data.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      data.remove_prefix(static_cast<std::size_t>(n));
    }
    return fd_ >= 0;
  }
  // Appends what arrives until EOF (true), or until stop(buffer) holds (true), or the deadline (false).
  bool read(std::string& out, Clock::time_point deadline, const std::function<bool(const std::string&)>& stop = {}) {
    char buf[65536];
    for (;;) {
      if (stop && stop(out)) return true;
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left <= 0 || fd_ < 0) return false;
      pollfd p{fd_, POLLIN, 0};
      const int r = ::poll(&p, 1, static_cast<int>(std::min<long long>(left, 1000)));
      if (r < 0) return false;
      if (r == 0) continue;
      const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
      if (n <= 0) return true;  // EOF or reset: the server closed
      out.append(buf, static_cast<std::size_t>(n));
    }
  }
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

struct Reply {
  int status = 0;  // 0: no (parseable) response
  std::string head, body, content_type;
  bool timed_out = false;
};

// Parses the responses in a byte stream (Content-Length framed, as the server writes them).
inline std::vector<Reply> parse_replies(const std::string& data, bool* complete = nullptr) {
  std::vector<Reply> out;
  std::size_t pos = 0;
  if (complete) *complete = true;
  while (pos < data.size()) {
    const std::size_t end = data.find("\r\n\r\n", pos);
    if (end == std::string::npos) {
      if (complete) *complete = false;
      break;
    }
    Reply r;
    r.head = data.substr(pos, end - pos);
    if (r.head.rfind("HTTP/1.", 0) == 0 && r.head.size() >= 12) r.status = std::atoi(r.head.c_str() + 9);
    std::size_t length = 0;
    std::istringstream hs(r.head);
    for (std::string line; std::getline(hs, line);) {
      std::string lower = line;
      for (auto& c : lower) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
      if (lower.rfind("content-length:", 0) == 0) length = std::strtoull(line.c_str() + 15, nullptr, 10);
      if (lower.rfind("content-type:", 0) == 0) {
        r.content_type = line.substr(13);
        r.content_type.erase(0, r.content_type.find_first_not_of(' '));
        while (!r.content_type.empty() && (r.content_type.back() == '\r' || r.content_type.back() == ' '))
          r.content_type.pop_back();
      }
    }
    const std::size_t body = end + 4;
    if (data.size() - body < length) {
      if (complete) *complete = false;
      r.body = data.substr(body);
      out.push_back(std::move(r));
      break;
    }
    r.body = data.substr(body, length);
    out.push_back(std::move(r));
    pos = body + length;
  }
  return out;
}

// One exchange: sends `request` and reads until the server closes or `want` responses are complete.
inline std::vector<Reply> exchange(int port, const std::string& request, double timeout, std::size_t want = 1,
                                   bool* timed_out = nullptr) {
  Socket s(port);
  if (timed_out) *timed_out = false;
  if (!s.ok()) return {};
  s.send(request);
  std::string data;
  const bool ended = s.read(data, Clock::now() + std::chrono::milliseconds(static_cast<long>(timeout * 1000)),
                            [want](const std::string& d) {
                              bool complete = false;
                              const auto r = parse_replies(d, &complete);
                              return complete && r.size() >= want;
                            });
  if (!ended && timed_out) *timed_out = true;
  return parse_replies(data);
}

inline std::string http(const std::string& method, const std::string& target, const std::string& body = "",
                        const std::string& session = "", const std::string& extra_headers = "") {
  std::string r = method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  if (!session.empty()) r += "X-Distlab-Session: " + session + "\r\n";
  if (!body.empty() || method == "POST" || method == "PUT")
    r += "Content-Type: application/json\r\nContent-Length: " + std::to_string(body.size()) + "\r\n";
  return r + extra_headers + "\r\n" + body;
}

// ---------------------------------------------------------------------------------------------
// Answer checks.

// Bare identifiers outside strings other than true/false/null: NaN, Infinity, nan, inf, ...
inline bool has_nonfinite_token(const std::string& text) {
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\') ++i;
      else if (c == '"') in_string = false;
      continue;
    }
    if (c == '"') {
      in_string = true;
    } else if (std::isalpha(static_cast<unsigned char>(c))) {
      std::size_t j = i;
      while (j < text.size() && std::isalpha(static_cast<unsigned char>(text[j]))) ++j;
      const std::string word = text.substr(i, j - i);
      if (word != "true" && word != "false" && word != "null" && word != "e" && word != "E") return true;
      i = j - 1;
    }
  }
  return false;
}

// Non-finite float32 in a msgpack frame's positions/scalars, or a non-finite number anywhere.
inline bool frame_nonfinite(const json& j) {
  if (j.is_number_float()) return !std::isfinite(j.get<double>());
  if (j.is_binary()) return false;
  if (j.is_object()) {
    for (const char* key : {"positions", "scalars", "weak", "strict"})
      if (j.contains(key) && j[key].is_binary()) {
        const auto& b = j[key].get_binary();
        for (std::size_t i = 0; i + 4 <= b.size(); i += 4) {
          float f;
          std::memcpy(&f, b.data() + i, 4);
          if (!std::isfinite(f)) return true;
        }
      }
    for (const auto& [k, v] : j.items())
      if (frame_nonfinite(v)) return true;
  }
  if (j.is_array())
    for (const auto& v : j)
      if (frame_nonfinite(v)) return true;
  return false;
}

// Nulls among numbers that must be numbers (GAP results, iso-surface metadata).
inline bool null_in(const json& j, const std::vector<std::string>& keys) {
  if (j.is_object()) {
    for (const auto& k : keys)
      if (j.contains(k)) {
        const json& v = j[k];
        if (v.is_null()) return true;
        if (v.is_array())
          for (const auto& x : v)
            if (x.is_null()) return true;
      }
    for (const auto& [k, v] : j.items())
      if (null_in(v, keys)) return true;
  } else if (j.is_array()) {
    for (const auto& v : j)
      if (null_in(v, keys)) return true;
  }
  return false;
}

// ---------------------------------------------------------------------------------------------
// Cases.

enum class Expect {
  ok,        // 2xx
  client,    // 4xx
  any,       // 2xx or 4xx (a valid but odd request, where either answer is fine)
  no_reply,  // the client hangs up: no answer needed, the server just must survive
  status     // exactly Case::status
};

struct Ctx {
  int port = 0;
  std::string session, other_session;  // other: a second session owning its own resources
  std::string object, other_object;    // ready Kelvin objects (cube)
  std::string other_upload, other_job, other_rollout, rollout, job;
  std::string upload_session;   // uploads go here (rotated before the per-session cap)
  std::string other_recording;  // a recording of the other session (scene suite)
  std::string web_dir;
  int uploads_in_session = 0;
};

struct Outcome {
  std::vector<Reply> replies;
  bool timed_out = false;
  std::string problem;  // a custom check's failure, "" if none
};

struct Case {
  std::string name;                          // category/name
  std::function<std::string(Ctx&)> request;  // raw bytes (may prepare state, e.g. a fresh upload session)
  Expect expect = Expect::client;
  int status = 0;
  double timeout = 30;
  std::size_t replies = 1;  // pipelined requests: this many answers expected
  // Extra checks of the (first) answer: return a problem, or "".
  std::function<std::string(const Reply&, Ctx&)> check;
  // A case that drives the server itself (slow clients, WebSocket): returns a problem or "".
  std::function<Outcome(Ctx&)> custom;
  std::string why;  // the defect a failure points to (issue item), for the report
};

// The start of an answer for the report (binary answers by their type and size).
inline std::string excerpt(const Reply& r) {
  if (r.content_type.find("json") != std::string::npos || r.content_type.rfind("text/", 0) == 0) return r.body.substr(0, 160);
  return "<" + (r.content_type.empty() ? std::string("no type") : r.content_type) + ", " + std::to_string(r.body.size()) + " bytes>";
}

inline std::string category(const std::string& name) { return name.substr(0, name.find('/')); }

struct Tally {
  std::size_t cases = 0;
  std::vector<std::string> crashes, hangs, nonfinite, server_errors, wrong, restarts;
  std::map<std::string, std::size_t> per_category;
};

class Runner {
 public:
  // extra: server options; setup(ctx): creates the sessions and objects the cases refer to.
  Runner(std::vector<std::string> extra, std::function<void(Ctx&, ServerProcess&)> setup)
      : extra_(std::move(extra)), setup_(std::move(setup)), cache_("distlab-hostile-cache") {
    start();
  }
  ~Runner() {
    if (server_) server_->stop();
  }

  ServerProcess& server() { return *server_; }
  Ctx& ctx() { return ctx_; }
  const Tally& tally() const { return tally_; }

  void run(const Case& c) {
    ++tally_.cases;
    ++tally_.per_category[category(c.name)];
    Outcome o;
    if (c.custom) {
      o = c.custom(ctx_);
    } else {
      bool timed_out = false;
      o.replies = exchange(ctx_.port, c.request(ctx_), c.timeout, c.replies, &timed_out);
      o.timed_out = timed_out;
    }
    std::string problem = o.problem;
    bool server_error = false, nonfinite = false;
    for (const Reply& r : o.replies) {
      if (r.status >= 500) server_error = true;
      if (r.content_type.find("json") != std::string::npos && has_nonfinite_token(r.body)) nonfinite = true;
      if (r.content_type == "application/msgpack" && r.status == 200) {
        const json j = json::from_msgpack(r.body, true, false);
        if (j.is_discarded() || frame_nonfinite(j)) nonfinite = true;
      }
    }
    if (!c.custom) {
      const int st = o.replies.empty() ? 0 : o.replies.front().status;
      if (o.timed_out && c.expect != Expect::no_reply)
        problem += " no complete answer within " + std::to_string(static_cast<int>(c.timeout)) + " s;";
      else if (o.replies.size() < c.replies && c.expect != Expect::no_reply)
        problem += " " + std::to_string(o.replies.size()) + " answers of " + std::to_string(c.replies) + ";";
      const bool fits = (c.expect == Expect::ok && st >= 200 && st < 300) ||
                        (c.expect == Expect::client && st >= 400 && st < 500) ||
                        (c.expect == Expect::any && st >= 200 && st < 500) || c.expect == Expect::no_reply ||
                        (c.expect == Expect::status && st == c.status);
      if (!fits && !o.timed_out && o.replies.empty())
        problem += " no answer;";
      else if (!fits && !o.timed_out && !(st >= 500))
        problem += " answered " + std::to_string(st) + " (" + excerpt(o.replies.front()) + ");";
      if (c.check && !o.replies.empty() && st > 0 && st < 500) problem += c.check(o.replies.front(), ctx_);
      // A request that started a job the suite does not need: stop it at once, forget its object.
      if (!o.replies.empty() && st == 202 && c.expect != Expect::ok) cancel_started(o.replies.front());
    }
    const std::string label = c.name + (c.why.empty() ? "" : " [" + c.why + "]");
    if (server_error) tally_.server_errors.push_back(label + ": " + first_status(o));
    if (nonfinite) tally_.nonfinite.push_back(label);
    // Health after every case; a dead server is a crash, a silent one a hang. Both restart it.
    const int health = health_status();
    if (health != 200) {
      const bool dead = !alive();
      (dead ? tally_.crashes : tally_.hangs).push_back(label);
      std::fprintf(stderr, "hostile: the server %s after %s; restarting\n", dead ? "died" : "stopped answering",
                   c.name.c_str());
      restart();
    } else if (o.timed_out && c.expect != Expect::no_reply) {
      tally_.hangs.push_back(label + ":" + problem);
    } else if (!problem.empty()) {
      tally_.wrong.push_back(label + ":" + problem);
    }
  }

  void run_all(const std::vector<Case>& cases) {
    for (const auto& c : cases) run(c);
  }

  // Prints the counts and the failing cases; EXPECTs every count to be 0.
  void report(const std::string& title) {
    std::printf("\n=== hostile suite: %s ===\n", title.c_str());
    for (const auto& [cat, n] : tally_.per_category) std::printf("  %-12s %4zu cases\n", cat.c_str(), n);
    std::printf("cases %zu, crashes %zu, hangs %zu, NaN/inf %zu, 5xx %zu, wrong answers %zu\n", tally_.cases,
                tally_.crashes.size(), tally_.hangs.size(), tally_.nonfinite.size(), tally_.server_errors.size(),
                tally_.wrong.size());
    auto list = [](const char* what, const std::vector<std::string>& v) {
      for (const auto& s : v) std::printf("  %s: %s\n", what, s.c_str());
    };
    list("CRASH", tally_.crashes);
    list("HANG", tally_.hangs);
    list("NONFINITE", tally_.nonfinite);
    list("5XX", tally_.server_errors);
    list("WRONG", tally_.wrong);
    std::fflush(stdout);
    // A clean exit too: a sanitizer report at exit (a leak) fails here.
    const int code = server_->stop();
    EXPECT_EQ(code, 0) << "the server's exit status after the last case [a sanitizer report at exit: 13 importer leak?]";
    EXPECT_EQ(tally_.crashes.size(), 0u);
    EXPECT_EQ(tally_.hangs.size(), 0u);
    EXPECT_EQ(tally_.nonfinite.size(), 0u);
    EXPECT_EQ(tally_.server_errors.size(), 0u);
    EXPECT_EQ(tally_.wrong.size(), 0u);
  }

  int health_status(double timeout = 10) {
    for (int attempt = 0; attempt < 2; ++attempt) {
      const auto r = exchange(ctx_.port, http("GET", "/api/health"), timeout);
      if (!r.empty() && r.front().status == 200) return 200;
      if (!alive()) return 0;
    }
    return 0;
  }

  bool alive() const {
    std::ifstream stat("/proc/" + std::to_string(server_->pid()) + "/stat");
    std::string pid, comm, state;
    stat >> pid >> comm >> state;
    return stat && state != "Z" && state != "X";
  }

  void restart() {
    const int code = server_->stop();
    std::fprintf(stderr, "hostile: server exit status %d\n", code);
    tally_.restarts.push_back(std::to_string(code));
    start();
  }

 private:
  static std::string first_status(const Outcome& o) {
    for (const auto& r : o.replies)
      if (r.status >= 500) return std::to_string(r.status) + " " + excerpt(r);
    return "";
  }

  void cancel_started(const Reply& r) {
    const json j = json::parse(r.body, nullptr, false);
    if (!j.is_object() || !j.contains("job") || !j["job"].is_object() || !j["job"].contains("id")) return;
    const std::string job = j["job"]["id"], s = ctx_.session;
    exchange(ctx_.port, http("POST", "/api/jobs/" + job + "/cancel", "", s), 10);
    // Let it stop (bounded) so that its memory and time do not spill into the next case.
    for (int i = 0; i < 100; ++i) {
      const auto a = exchange(ctx_.port, http("GET", "/api/jobs/" + job, "", s), 10);
      if (a.empty()) break;
      const json st = json::parse(a.front().body, nullptr, false);
      if (!st.is_object() || (st.value("state", "") != "running" && st.value("state", "") != "queued")) break;
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    if (j.contains("object") && j["object"].is_object() && j["object"].contains("id"))
      exchange(ctx_.port, http("DELETE", "/api/kelvin/objects/" + j["object"]["id"].get<std::string>(), "", s), 10);
  }

  void start() {
    // The server's limits: no core dumps; memory bounded so a hostile allocation fails instead of
    // taking the shared machine (ASan: through its own options, as it reserves a huge address space).
    // DISTLAB_SERVER_ASAN (tests/server/CMakeLists.txt): the server is, whatever this unit is.
#if defined(DISTLAB_SERVER_ASAN)
    std::string asan = std::getenv("ASAN_OPTIONS") ? std::getenv("ASAN_OPTIONS") : "";
    if (asan.find("hard_rss_limit_mb") == std::string::npos)
      asan += std::string(asan.empty() ? "" : ":") + "hard_rss_limit_mb=4096:max_allocation_size_mb=3072";
    ::setenv("ASAN_OPTIONS", asan.c_str(), 1);
#endif
    server_ = std::make_unique<ServerProcess>(extra_, cache_.path());
    rlimit core{0, 0};
    ::prlimit(server_->pid(), RLIMIT_CORE, &core, nullptr);
#if !defined(DISTLAB_SERVER_ASAN)
    rlimit as{std::size_t{4} << 30, std::size_t{4} << 30};
    ::prlimit(server_->pid(), RLIMIT_AS, &as, nullptr);
#endif
    ctx_ = Ctx{};
    ctx_.port = server_->port();
    setup_(ctx_, *server_);
  }

  std::vector<std::string> extra_;
  std::function<void(Ctx&, ServerProcess&)> setup_;
  TempDir cache_;
  std::unique_ptr<ServerProcess> server_;
  Ctx ctx_;
  Tally tally_;
};

}  // namespace distlab::test::hostile
