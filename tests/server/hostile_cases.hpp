#pragma once
// The hostile corpus, generated from compact tables: HTTP framing, JSON text, every route's
// domain values, uploads in every accepted format, sessions, WebSocket frames and static paths.
// Each case names the request and the class of answer it must get (hostile_harness.hpp).
#include <cstdint>
#include <tuple>

#include "fuzz/mesh_bytes.hpp"
#include "server/hostile_harness.hpp"

namespace distlab::test::hostile {

using namespace distlab::test::mesh_bytes;

// ---------------------------------------------------------------------------------------------
// Shared helpers.

inline Reply call(Ctx& ctx, const std::string& method, const std::string& target, const std::string& body = "",
                  const std::string& session = "") {
  const auto r = exchange(ctx.port, http(method, target, body, session), 60);
  return r.empty() ? Reply{} : r.front();
}

inline std::string make_session(Ctx& ctx) {
  const json j = json::parse(call(ctx, "POST", "/api/session").body, nullptr, false);
  return j.is_object() && j.contains("session") ? j["session"].get<std::string>() : "";
}

// Waits for a job to end (bounded); returns its final JSON.
inline json wait_job(Ctx& ctx, const std::string& session, const std::string& job, double seconds = 300) {
  const auto end = Clock::now() + std::chrono::milliseconds(static_cast<long>(seconds * 1000));
  json st;
  while (Clock::now() < end) {
    st = json::parse(call(ctx, "GET", "/api/jobs/" + job, "", session).body, nullptr, false);
    if (!st.is_object() || (st.value("state", "") != "running" && st.value("state", "") != "queued")) return st;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return st;
}

// A ready cube object of the session (the suite's shared fixture).
inline std::string ready_cube(Ctx& ctx, const std::string& session) {
  const json j = json::parse(
      call(ctx, "POST", "/api/kelvin/objects", json{{"asset", "cube"}, {"lx", 0.2}}.dump(), session).body, nullptr,
      false);
  if (!j.is_object() || !j.contains("job")) return "";
  const json st = wait_job(ctx, session, j["job"]["id"]);
  EXPECT_EQ(st.value("state", ""), "succeeded") << st.dump();
  return j["object"]["id"];
}

inline const char* kTetraObj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n";

// A short corridor rollout (5 steps).
inline std::string short_rollout(Ctx& ctx, const std::string& session) {
  const json j = json::parse(call(ctx, "POST", "/api/cbf/rollouts",
                                  json{{"scenario", "corridor"}, {"params", {{"duration", 0.05}}}}.dump(), session)
                                 .body,
                             nullptr, false);
  if (!j.is_object() || !j.contains("rollout")) return "";
  return j["rollout"]["id"];
}

inline void standard_setup(Ctx& ctx, ServerProcess& server) {
  ctx.web_dir = server.web_dir();
  ctx.session = make_session(ctx);
  ctx.other_session = make_session(ctx);
  ctx.object = ready_cube(ctx, ctx.session);
  ctx.other_object = ready_cube(ctx, ctx.other_session);
  const json up = json::parse(call(ctx, "POST", "/api/kelvin/uploads?format=obj", kTetraObj, ctx.other_session).body,
                              nullptr, false);
  ctx.other_upload = up.is_object() && up.contains("upload") ? up["upload"].get<std::string>() : "";
  ctx.other_rollout = short_rollout(ctx, ctx.other_session);
  ctx.other_job = ctx.other_rollout;  // a rollout's id is its job's id
  ctx.rollout = short_rollout(ctx, ctx.session);
  ctx.job = ctx.rollout;
  wait_job(ctx, ctx.session, ctx.rollout, 120);
  wait_job(ctx, ctx.other_session, ctx.other_rollout, 120);
}

inline Case make(std::string name, std::function<std::string(Ctx&)> request, Expect expect = Expect::client,
                 std::string why = "") {
  Case c;
  c.name = std::move(name);
  c.request = std::move(request);
  c.expect = expect;
  c.why = std::move(why);
  return c;
}

// A request to `target` with `body` in the suite's session.
inline Case api(std::string name, std::string method, std::string target, std::string body,
                Expect expect = Expect::client, std::string why = "") {
  return make(
      std::move(name),
      [method, target, body](Ctx& c) {
        std::string t = target;
        for (const auto& [k, v] : {std::pair<std::string, std::string>{"{object}", c.object},
                                   {"{other_object}", c.other_object},
                                   {"{rollout}", c.rollout},
                                   {"{other_rollout}", c.other_rollout},
                                   {"{job}", c.job},
                                   {"{other_job}", c.other_job}})
          for (std::size_t p; (p = t.find(k)) != std::string::npos;) t.replace(p, k.size(), v);
        std::string b = body;
        for (std::size_t p; (p = b.find("{other_upload}")) != std::string::npos;) b.replace(p, 14, c.other_upload);
        return http(method, t, b, c.session);
      },
      expect, std::move(why));
}

inline std::string repeat(const std::string& s, std::size_t n) {
  std::string out;
  out.reserve(s.size() * n);
  for (std::size_t i = 0; i < n; ++i) out += s;
  return out;
}

// Every leaf of j with its JSON pointer.
inline void leaves(const json& j, const std::string& path, std::vector<std::pair<std::string, json>>& out) {
  if (j.is_object()) {
    for (const auto& [k, v] : j.items()) leaves(v, path + "/" + k, out);
  } else if (j.is_array() && !j.empty() && !j[0].is_structured()) {
    out.emplace_back(path, j);
    for (std::size_t i = 0; i < j.size(); ++i) leaves(j[i], path + "/" + std::to_string(i), out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) leaves(j[i], path + "/" + std::to_string(i), out);
  } else {
    out.emplace_back(path, j);
  }
}

// Every object inside j (pointers), for unknown-key cases.
inline void objects(const json& j, const std::string& path, std::vector<std::string>& out) {
  if (j.is_object()) {
    out.push_back(path);
    for (const auto& [k, v] : j.items()) objects(v, path + "/" + k, out);
  } else if (j.is_array()) {
    for (std::size_t i = 0; i < j.size(); ++i) objects(j[i], path + "/" + std::to_string(i), out);
  }
}

// For a valid request body: each leaf replaced by a value of a wrong type (4xx), each number by
// extreme values (any answer but a 5xx / NaN), and an unknown key added to every object (4xx).
inline void mutate_body(std::vector<Case>& out, const std::string& prefix, const std::string& method,
                        const std::string& target, const json& valid, bool extremes = true,
                        std::function<std::string(const Reply&, Ctx&)> check = {},
                        const std::set<std::string>& lenient = {}) {
  std::vector<std::pair<std::string, json>> ls;
  leaves(valid, "", ls);
  for (const auto& [ptr, value] : ls) {
    std::vector<std::pair<std::string, json>> wrong;
    if (value.is_number()) wrong = {{"string", "1"}, {"null", nullptr}, {"bool", true}, {"array", json::array()}, {"object", json::object()}};
    else if (value.is_string()) wrong = {{"number", 1}, {"null", nullptr}, {"array", json::array({"x"})}};
    else if (value.is_boolean()) wrong = {{"number", 1}, {"string", "true"}, {"null", nullptr}};
    else if (value.is_array()) wrong = {{"short", json::array({1})}, {"string", "[1,2,3]"}, {"nested", json::array({json::array({1, 2, 3})})}};
    for (const auto& [kind, w] : wrong) {
      json b = valid;
      b[json::json_pointer(ptr)] = w;
      out.push_back(api(prefix + "/type" + ptr + "=" + kind, method, target, b.dump(),
                        lenient.count(ptr) ? Expect::any : Expect::client));
      if (check) out.back().check = check;
    }
    if (extremes && value.is_number()) {
      const std::vector<std::pair<std::string, json>> xs = {
          {"0", 0}, {"-1", -1}, {"1e300", 1e300}, {"-1e300", -1e300}, {"1e-300", 1e-300}, {"1e7", 1e7}, {"2^63", 9223372036854775807LL}};
      for (const auto& [kind, x] : xs) {
        json b = valid;
        b[json::json_pointer(ptr)] = x;
        out.push_back(api(prefix + "/value" + ptr + "=" + kind, method, target, b.dump(), Expect::any));
        if (check) out.back().check = check;
      }
    }
  }
  std::vector<std::string> objs;
  objects(valid, "", objs);
  for (const auto& ptr : objs) {
    json b = valid;
    b[json::json_pointer(ptr + "/zz_unknown")] = 1;
    out.push_back(api(prefix + "/unknown_key" + (ptr.empty() ? "/" : ptr), method, target, b.dump(), Expect::client,
                      "13 unknown keys"));
  }
}

// Numbers that must be numbers in a 200 answer.
inline std::function<std::string(const Reply&, Ctx&)> no_null(std::vector<std::string> keys) {
  return [keys](const Reply& r, Ctx&) -> std::string {
    if (r.status != 200) return "";
    const json j = json::parse(r.body, nullptr, false);
    if (j.is_discarded()) return " answer is not JSON;";
    return null_in(j, keys) ? " null where a number is due;" : "";
  };
}

inline std::function<std::string(const Reply&, Ctx&)> field_is(std::string field) {
  return [field](const Reply& r, Ctx&) -> std::string {
    const json j = json::parse(r.body, nullptr, false);
    if (!j.is_object() || !j.contains("error")) return " no error object;";
    if (j["error"].value("field", "") != field)
      return " error names field \"" + j["error"].value("field", "") + "\", not \"" + field + "\";";
    return "";
  };
}

// ---------------------------------------------------------------------------------------------
// HTTP framing (raw bytes).

inline void framing_cases(std::vector<Case>& out) {
  auto raw = [&](std::string name, std::string bytes, Expect e = Expect::client, std::size_t replies = 1,
                 std::string why = "") {
    Case c = make(
        "framing/" + name, [bytes](Ctx&) { return bytes; }, e, why);
    c.replies = replies;
    c.timeout = e == Expect::no_reply ? 2 : 40;
    out.push_back(c);
  };
  const std::string H = "Host: 127.0.0.1\r\nConnection: close\r\n";
  raw("garbage", "GARBAGE\r\n\r\n");
  raw("empty_line_only", "\r\n\r\n");
  raw("method_only", "GET\r\n\r\n");
  raw("no_version", "GET /api/health\r\n\r\n");
  raw("http_0_9", "GET /\r\n", Expect::any);
  raw("version_9_9", "GET /api/health HTTP/9.9\r\n" + H + "\r\n", Expect::any);
  raw("version_garbage", "GET /api/health HTTP/x.y\r\n" + H + "\r\n");
  raw("version_2", "GET /api/health HTTP/2.0\r\n" + H + "\r\n", Expect::any);
  raw("lowercase_method", "get /api/health HTTP/1.1\r\n" + H + "\r\n", Expect::any);
  raw("unknown_method", "BREW /api/health HTTP/1.1\r\n" + H + "\r\n");
  raw("method_with_nul", std::string("G\0T /api/health HTTP/1.1\r\n", 26) + H + "\r\n");
  raw("method_64k", std::string(65536, 'G') + " /api/health HTTP/1.1\r\n" + H + "\r\n");
  raw("target_no_slash", "GET api/health HTTP/1.1\r\n" + H + "\r\n");
  raw("target_star", "OPTIONS * HTTP/1.1\r\n" + H + "\r\n");
  raw("connect", "CONNECT 127.0.0.1:22 HTTP/1.1\r\n" + H + "\r\n");
  raw("trace", "TRACE /api/health HTTP/1.1\r\n" + H + "\r\n");
  raw("absolute_form", "GET http://127.0.0.1/api/health HTTP/1.1\r\n" + H + "\r\n", Expect::any);
  raw("target_8k", "GET /api/" + std::string(8192, 'a') + " HTTP/1.1\r\n" + H + "\r\n");
  raw("target_20k", "GET /api/" + std::string(20000, 'a') + " HTTP/1.1\r\n" + H + "\r\n");
  raw("query_1000_params", "GET /api/health?" + repeat("a=1&", 1000) + " HTTP/1.1\r\n" + H + "\r\n", Expect::any);
  raw("query_bad_percent", "GET /api/health?%zz=%&x=%4 HTTP/1.1\r\n" + H + "\r\n", Expect::any);
  raw("target_fragment", "GET /api/health#x HTTP/1.1\r\n" + H + "\r\n", Expect::any);
  raw("target_space", "GET /api/ health HTTP/1.1\r\n" + H + "\r\n");
  raw("target_ctl", "GET /api/\x01health HTTP/1.1\r\n" + H + "\r\n");
  raw("lf_only", "GET /api/health HTTP/1.1\nHost: x\nConnection: close\n\n", Expect::any);
  raw("cr_only", "GET /api/health HTTP/1.1\rHost: x\r\r");
  raw("no_host", "GET /api/health HTTP/1.1\r\nConnection: close\r\n\r\n", Expect::any);
  raw("header_no_colon", "GET /api/health HTTP/1.1\r\n" + H + "NoColonHere\r\n\r\n");
  raw("header_space_in_name", "GET /api/health HTTP/1.1\r\n" + H + "Bad Name: x\r\n\r\n");
  raw("header_nul_value", "GET /api/health HTTP/1.1\r\n" + H + std::string("X-A: a\0b\r\n", 10) + "\r\n");
  raw("header_obs_fold", "GET /api/health HTTP/1.1\r\n" + H + "X-A: a\r\n  folded\r\n\r\n", Expect::any);
  raw("header_17k", "GET /api/health HTTP/1.1\r\n" + H + "X-Big: " + std::string(17 * 1024, 'x') + "\r\n\r\n");
  raw("header_1m", "GET /api/health HTTP/1.1\r\n" + H + "X-Big: " + std::string(1 << 20, 'x') + "\r\n\r\n");
  raw("headers_3000", "GET /api/health HTTP/1.1\r\n" + H + repeat("X-A: b\r\n", 3000) + "\r\n", Expect::any);
  raw("headers_100k", "GET /api/health HTTP/1.1\r\n" + H + repeat("X-A: b\r\n", 100000) + "\r\n");
  raw("host_17k", "GET /api/health HTTP/1.1\r\nHost: " + std::string(17000, 'h') + "\r\nConnection: close\r\n\r\n");
  raw("session_header_10k", "GET /api/session HTTP/1.1\r\n" + H + "X-Distlab-Session: " + std::string(10000, 'a') + "\r\n\r\n");
  raw("cookie_many", "GET /api/session HTTP/1.1\r\n" + H + "Cookie: " + repeat("a=b; ", 2000) + "distlab_session=zz\r\n\r\n");
  const std::string post = "POST /api/gap/distance HTTP/1.1\r\n" + H;
  raw("cl_negative", post + "Content-Length: -1\r\n\r\n{}");
  raw("cl_text", post + "Content-Length: abc\r\n\r\n{}");
  raw("cl_float", post + "Content-Length: 1e3\r\n\r\n{}");
  raw("cl_hex", post + "Content-Length: 0x10\r\n\r\n{}");
  raw("cl_huge", post + "Content-Length: 99999999999999999999999\r\n\r\n{}");
  raw("cl_2_63", post + "Content-Length: 9223372036854775808\r\n\r\n{}");
  raw("cl_over_limit", post + "Content-Length: 9000000\r\n\r\n{}");
  raw("cl_two_different", post + "Content-Length: 2\r\nContent-Length: 3\r\n\r\n{}x");
  raw("cl_two_same", post + "Content-Length: 2\r\nContent-Length: 2\r\n\r\n{}", Expect::client);
  raw("cl_list", post + "Content-Length: 2, 2\r\n\r\n{}", Expect::client);
  raw("cl_space_inside", post + "Content-Length: 1 0\r\n\r\n{}");
  raw("cl_and_chunked", post + "Content-Length: 4\r\nTransfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
  raw("cl_zero_with_body", post + "Content-Length: 0\r\n\r\n", Expect::client);
  raw("cl_larger_than_body_then_close", post + "Content-Length: 100\r\n\r\n{}", Expect::no_reply);
  raw("body_longer_than_cl", post + "Content-Length: 2\r\n\r\n{}GARBAGE AFTER", Expect::client);
  raw("te_gzip", post + "Transfer-Encoding: gzip\r\n\r\n{}");
  raw("te_chunked_gzip", post + "Transfer-Encoding: chunked, gzip\r\n\r\n2\r\n{}\r\n0\r\n\r\n");
  raw("te_unknown", post + "Transfer-Encoding: bogus\r\n\r\n{}");
  raw("chunked_bad_hex", post + "Transfer-Encoding: chunked\r\n\r\nzz\r\n{}\r\n0\r\n\r\n");
  raw("chunked_size_2_64", post + "Transfer-Encoding: chunked\r\n\r\nffffffffffffffff\r\n{}\r\n0\r\n\r\n");
  raw("chunked_size_over_limit", post + "Transfer-Encoding: chunked\r\n\r\n900000\r\n{}\r\n0\r\n\r\n");
  raw("chunked_negative", post + "Transfer-Encoding: chunked\r\n\r\n-2\r\n{}\r\n0\r\n\r\n");
  raw("chunked_no_terminator", post + "Transfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n", Expect::no_reply);
  raw("chunked_missing_crlf", post + "Transfer-Encoding: chunked\r\n\r\n2\r\n{}0\r\n\r\n");
  raw("chunked_ext_16k", post + "Transfer-Encoding: chunked\r\n\r\n2;" + std::string(16384, 'e') + "\r\n{}\r\n0\r\n\r\n");
  raw("chunked_trailer_big", post + "Transfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n" + repeat("X-T: aaaaaaaaaaaaaaaa\r\n", 2000) + "\r\n");
  raw("chunked_many_tiny", post + "Transfer-Encoding: chunked\r\n\r\n" + repeat("1\r\n \r\n", 20000) + "2\r\n{}\r\n0\r\n\r\n");
  raw("chunked_valid_json", post + "Transfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n", Expect::client);
  raw("chunked_http10", "POST /api/gap/distance HTTP/1.0\r\nTransfer-Encoding: chunked\r\n\r\n2\r\n{}\r\n0\r\n\r\n", Expect::any);
  raw("expect_100", post + "Expect: 100-continue\r\nContent-Length: 2\r\n\r\n{}", Expect::client);
  raw("expect_bogus", post + "Expect: bogus\r\nContent-Length: 2\r\n\r\n{}", Expect::any);
  raw("get_with_body", "GET /api/health HTTP/1.1\r\n" + H + "Content-Length: 5\r\n\r\nhello", Expect::any);
  raw("head_api", "HEAD /api/limits HTTP/1.1\r\n" + H + "\r\n", Expect::ok);
  raw("delete_on_get_route", "DELETE /api/health HTTP/1.1\r\n" + H + "\r\n", Expect::status);
  out.back().status = 405;
  raw("patch_route", "PATCH /api/gap/distance HTTP/1.1\r\n" + H + "Content-Length: 2\r\n\r\n{}", Expect::status);
  out.back().status = 405;
  raw("upgrade_not_ws_path", "GET /api/health HTTP/1.1\r\n" + H.substr(0, 17) +
                                 "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n");
  raw("upgrade_no_session", "GET /ws HTTP/1.1\r\n" + H.substr(0, 17) +
                                "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n");
  raw("upgrade_bad_version", "GET /ws?session=0 HTTP/1.1\r\n" + H.substr(0, 17) +
                                 "Connection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 99\r\nSec-WebSocket-Key: x\r\n\r\n");
  raw("upgrade_h2c", "GET /api/health HTTP/1.1\r\n" + H.substr(0, 17) + "Connection: Upgrade, HTTP2-Settings\r\nUpgrade: h2c\r\nHTTP2-Settings: AAMAAABkAAQAAP__\r\n\r\n", Expect::any);
  raw("h2_preface", "PRI * HTTP/2.0\r\n\r\nSM\r\n\r\n");
  raw("tls_client_hello", std::string("\x16\x03\x01\x00\xa5\x01\x00\x00\xa1\x03\x03", 11) + std::string(160, 'A'));
  raw("binary_junk", [] {
    std::string s(4096, '\0');
    std::mt19937 g(7);
    for (auto& c : s) c = static_cast<char>(g());
    return s;
  }());
  // Pipelining: several requests in one write; every one answered, in order.
  raw("pipeline_3_health", repeat("GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n", 2) + "GET /api/health HTTP/1.1\r\n" + H + "\r\n",
      Expect::ok, 3);
  raw("pipeline_100_health", repeat("GET /api/health HTTP/1.1\r\nHost: x\r\n\r\n", 99) + "GET /api/health HTTP/1.1\r\n" + H + "\r\n",
      Expect::ok, 100);
  raw("pipeline_bad_then_good", "POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nContent-Length: 1\r\n\r\n{GET /api/health HTTP/1.1\r\n" + H + "\r\n",
      Expect::client, 2);
  raw("pipeline_good_then_garbage", "GET /api/health HTTP/1.1\r\nHost: x\r\n\r\nGARBAGE\r\n\r\n", Expect::ok, 2);
  raw("pipeline_heavy_mix", repeat("POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nContent-Length: 2\r\n\r\n[]", 20) + "GET /api/health HTTP/1.1\r\n" + H + "\r\n", Expect::client, 21);
  raw("http10_keepalive", "GET /api/health HTTP/1.0\r\nConnection: keep-alive\r\n\r\nGET /api/health HTTP/1.0\r\n\r\n", Expect::ok, 2);

  // Slow and partial clients (bounded waits): the server serves others meanwhile and survives.
  auto slow = [&](std::string name, std::vector<std::string> parts, int pause_ms, bool expect_answer) {
    Case c;
    c.name = "framing/slow_" + name;
    c.custom = [parts, pause_ms, expect_answer](Ctx& ctx) {
      Outcome o;
      Socket s(ctx.port);
      for (const auto& p : parts) {
        s.send(p);
        // Meanwhile another client must be served.
        const auto h = exchange(ctx.port, http("GET", "/api/health"), 10);
        if (h.empty() || h.front().status != 200) o.problem += " health not served while a slow client waits;";
        std::this_thread::sleep_for(std::chrono::milliseconds(pause_ms));
      }
      if (expect_answer) {
        std::string data;
        s.read(data, Clock::now() + std::chrono::seconds(20),
               [](const std::string& d) { bool done = false; return !parse_replies(d, &done).empty() && done; });
        o.replies = parse_replies(data);
        if (o.replies.empty()) o.problem += " no answer to a complete (slow) request;";
      }
      return o;
    };
    out.push_back(c);
  };
  slow("half_request_line", {"GET /api/hea"}, 300, false);
  slow("half_headers", {"GET /api/health HTTP/1.1\r\nHost: x\r\nX-A: "}, 300, false);
  slow("drip_request", {"GET /api/he", "alth HTTP/1.1\r\n", "Host: x\r\n", "Connection: close\r\n", "\r\n"}, 150, true);
  slow("partial_body", {"POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nContent-Length: 1000\r\n\r\n{\"a\":"}, 500, false);
  slow("partial_chunk", {"POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n10\r\n{\"a"}, 500, false);
  slow("headers_no_end", {"GET /api/health HTTP/1.1\r\nHost: x\r\n"}, 1000, false);
  slow("drip_body", {"POST /api/gap/distance HTTP/1.1\r\nHost: x\r\nConnection: close\r\nContent-Length: 2\r\n\r\n", "[", "]"}, 300, true);
  // Many idle connections at once (bounded: 64), then others are still served.
  Case idle;
  idle.name = "framing/idle_connections_64";
  idle.custom = [](Ctx& ctx) {
    Outcome o;
    std::vector<std::unique_ptr<Socket>> held;
    for (int i = 0; i < 64; ++i) {
      held.push_back(std::make_unique<Socket>(ctx.port));
      held.back()->send("GET /api/hea");
    }
    const auto h = exchange(ctx.port, http("GET", "/api/health"), 10);
    if (h.empty() || h.front().status != 200) o.problem = " health not served with 64 idle connections open;";
    return o;
  };
  out.push_back(idle);
  // Requests answered while the client does not read (a large answer, reader stalled), then reset.
  Case stall;
  stall.name = "framing/reader_stalls_then_resets";
  stall.custom = [](Ctx& ctx) {
    Outcome o;
    {
      Socket s(ctx.port);
      int small = 4096;
      ::setsockopt(s.fd(), SOL_SOCKET, SO_RCVBUF, &small, sizeof small);
      s.send(repeat("GET /api/openapi.json HTTP/1.1\r\nHost: x\r\n\r\n", 50));
      std::this_thread::sleep_for(std::chrono::milliseconds(500));
      linger l{1, 0};
      ::setsockopt(s.fd(), SOL_SOCKET, SO_LINGER, &l, sizeof l);  // close with RST
    }
    return o;
  };
  out.push_back(stall);
}

// ---------------------------------------------------------------------------------------------
// JSON text (on the GAP route, whose body is parsed first, and on the other JSON routes).

inline void json_cases(std::vector<Case>& out) {
  const json valid = {{"a", {{"type", "sphere"}, {"radius", 0.3}}},
                      {"b", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {1, 0, 0}}}}}}};
  auto text = [&](std::string name, std::string body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("json/" + name, "POST", "/api/gap/distance", body, e, why));
  };
  text("empty", "");
  text("space", " ");
  text("open_brace", "{");
  text("close_brace", "}");
  text("open_bracket", "[");
  text("missing_value", "{\"a\":}");
  text("nul", "nul");
  text("tru", "tru");
  text("trailing_garbage", valid.dump() + " x");
  text("two_documents", "{}{}");
  text("comment", "/* c */" + valid.dump());
  text("single_quotes", "{'a': 1}");
  text("unquoted_key", "{a: 1}");
  text("trailing_comma", "{\"a\": 1,}");
  text("array_trailing_comma", "[1,]");
  text("top_array", "[]");
  text("top_number", "1");
  text("top_string", "\"x\"");
  text("top_null", "null");
  text("top_true", "true");
  text("empty_object", "{}");
  for (const std::string lit : {"NaN", "-NaN", "Infinity", "-Infinity", "nan", "inf", "-inf", "1e999", "-1e999", "1e99999999999",
                                "0x10", "01", "+1", ".5", "1.", "-", "1e", "1e+", "--1", "1_000", "\"1\""}) {
    json b = valid;
    std::string s = b.dump();
    const std::string at = "\"radius\":0.3";
    s.replace(s.find(at), at.size(), "\"radius\":" + lit);
    text("number_" + lit, s);
  }
  // Extreme but legal numbers: underflow to 0 (a radius 0 is refused), huge integers.
  text("number_1e-999", [&] { std::string s = valid.dump(); s.replace(s.find("0.3"), 3, "1e-999"); return s; }());
  text("number_int_40_digits", [&] { std::string s = valid.dump(); s.replace(s.find("0.3"), 3, std::string(40, '9')); return s; }());
  text(
      "number_denormal", [&] { std::string s = valid.dump(); s.replace(s.find("0.3"), 3, "4.9e-324"); return s; }(), Expect::any);
  text(
      "number_1000_digits", [&] { std::string s = valid.dump(); s.replace(s.find("0.3"), 3, "0." + std::string(1000, '3')); return s; }(),
      Expect::any);
  text("deep_array_100k", std::string(100000, '['));
  text("deep_array_closed_10k", std::string(10000, '[') + std::string(10000, ']'));
  text("deep_object_10k", repeat("{\"a\":", 10000) + "1" + std::string(10000, '}'));
  text("depth_63", repeat("{\"a\":", 63) + "1" + std::string(63, '}'));
  text("depth_65", repeat("{\"a\":", 65) + "1" + std::string(65, '}'));
  text("deep_in_comment_field", "{\"comment\":" + std::string(5000, '[') + std::string(5000, ']') + "}");
  text("duplicate_key_top", "{\"a\":{\"type\":\"sphere\",\"radius\":0.3},\"a\":{\"type\":\"sphere\",\"radius\":0.3},\"b\":{\"type\":\"sphere\",\"radius\":0.3}}");
  text("duplicate_key_nested", "{\"a\":{\"type\":\"sphere\",\"radius\":0.3,\"radius\":-1},\"b\":{\"type\":\"sphere\",\"radius\":0.3}}");
  text("duplicate_key_params", "{\"a\":{\"type\":\"sphere\",\"radius\":0.3},\"b\":{\"type\":\"sphere\",\"radius\":0.3},\"params\":{\"k\":2,\"k\":3}}");
  text("bom", "\xEF\xBB\xBF" + valid.dump(), Expect::any);
  text("utf16", std::string("\xFF\xFE{\0}\0", 6));
  text("invalid_utf8_string", "{\"comment\":\"\xff\xfe\",\"a\":1}");
  text("invalid_utf8_key", "{\"\xc3\x28\":1}");
  text("overlong_utf8", "{\"comment\":\"\xc0\xaf\"}");
  text("lone_surrogate", "{\"comment\":\"\\ud800\"," + valid.dump().substr(1));
  text("bad_escape", "{\"comment\":\"\\q\"}");
  text("bad_unicode_escape", "{\"comment\":\"\\u12\"}");
  text("control_char_in_string", std::string("{\"comment\":\"a\x01", 14) + "\"}");
  text("nul_in_body", std::string("{\"a\"\0:1}", 8));
  text("nul_in_string", std::string("{\"comment\":\"a\\u0000b\",", 22) + valid.dump().substr(1), Expect::any);
  text("key_1mb", "{\"" + std::string(1 << 20, 'k') + "\":1}");
  text("string_4mb", "{\"comment\":\"" + std::string(4 << 20, 's') + "\"," + valid.dump().substr(1), Expect::any);
  text("body_over_limit", "{\"comment\":\"" + std::string((8 << 20) + 10, 's') + "\"}");
  text("array_1m_numbers", "{\"comment\":[" + repeat("1,", 1000000) + "1]}");
  text("object_100k_keys", [] {
    std::string s = "{";
    for (int i = 0; i < 100000; ++i) s += "\"k" + std::to_string(i) + "\":1,";
    s.back() = '}';
    return s;
  }());
  text("whitespace_4mb", std::string(4 << 20, ' ') + valid.dump(), Expect::any);
  text("valid_pair", valid.dump(), Expect::ok);
  out.back().check = no_null({"lambda", "distance", "witness_a", "witness_b", "gradient_a", "gradient_b"});
  // The same malformed texts on the other JSON routes.
  const std::vector<std::pair<std::string, std::string>> routes = {
      {"POST", "/api/gap/levelsets"}, {"POST", "/api/kelvin/objects"}, {"PUT", "/api/kelvin/objects/{object}/sigma"}, {"PUT", "/api/kelvin/objects/{object}/levels"}, {"POST", "/api/kelvin/objects/{object}/query"}, {"POST", "/api/cbf/rollouts"}};
  for (const auto& [m, route] : routes) {
    const std::string slug = route.substr(5);
    for (const auto& [name, body] : std::vector<std::pair<std::string, std::string>>{
             {"empty", ""}, {"open_brace", "{"}, {"NaN", "{\"x\":NaN}"}, {"1e999", "{\"x\":1e999}"}, {"deep", std::string(20000, '[')}, {"duplicate", "{\"x\":1,\"x\":2}"}, {"top_array", "[1,2]"}, {"top_null", "null"}, {"invalid_utf8", "{\"\xff\":1}"}})
      out.push_back(api("json/" + slug + "/" + name, m, route, body));
  }
}

// ---------------------------------------------------------------------------------------------
// GAP: shapes with degenerate sizes, params out of range, batches.

inline void gap_cases(std::vector<Case>& out) {
  const auto keys = std::vector<std::string>{"lambda", "distance", "witness_a", "witness_b", "gradient_a", "gradient_b"};
  const json sphere = {{"type", "sphere"}, {"radius", 0.3}};
  const json far_sphere = {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {2, 0, 0}}}}};
  auto pair = [&](std::string name, const json& a, const json& b, const json& params, Expect e, std::string why = "") {
    json body = {{"a", a}, {"b", b}};
    if (!params.is_null()) body["params"] = params;
    out.push_back(api("gap/" + name, "POST", "/api/gap/distance", body.dump(), e, why));
    out.back().check = no_null(keys);
  };
  // A quaternion whose norm overflows a double ([1e308, 1e308, 1e308, 1e308]) is the rotation of
  // [1, 1, 1, 1] (120° about the diagonal); its q / |q| was the zero quaternion, which Eigen turns
  // into the identity: the box was silently not rotated.
  {
    const json sphere_a = {{"type", "sphere"}, {"radius", 0.3}};
    auto turned = [](double q) { return json{{"type", "box"}, {"size", {0.4, 0.2, 0.1}}, {"pose", {{"position", {1, 0, 0}}, {"quaternion", {q, q, q, q}}}}}; };
    pair("pose_quaternion_1e308", sphere_a, turned(1e308), nullptr, Expect::ok, "new: an overflowing quaternion norm zeroed the rotation");
    out.back().check = [sphere_a, turned](const Reply& r, Ctx& ctx) -> std::string {
      const json got = json::parse(r.body, nullptr, false);
      const json want = json::parse(call(ctx, "POST", "/api/gap/distance", json{{"a", sphere_a}, {"b", turned(1)}}.dump()).body, nullptr, false);
      if (!got.is_object() || !want.is_object() || !got.contains("distance") || !want.contains("distance")) return " no distance to compare;";
      return got["distance"] == want["distance"] ? "" : " distance " + got["distance"].dump() + ", with the quaternion [1, 1, 1, 1] " + want["distance"].dump() + ";";
    };
  }
  // Shapes (as a): degenerate, out of range, malformed.
  const std::vector<std::pair<std::string, json>> bad_shapes = {
      {"box_zero", {{"type", "box"}, {"size", {0, 1, 1}}}},
      {"box_negative", {{"type", "box"}, {"size", {-1, 1, 1}}}},
      {"box_huge", {{"type", "box"}, {"size", {1e7, 1, 1}}}},
      {"box_1e300", {{"type", "box"}, {"size", {1e300, 1e300, 1e300}}}},
      {"box_two", {{"type", "box"}, {"size", {1, 1}}}},
      {"box_four", {{"type", "box"}, {"size", {1, 1, 1, 1}}}},
      {"box_no_size", {{"type", "box"}}},
      {"sphere_zero", {{"type", "sphere"}, {"radius", 0}}},
      {"sphere_negative", {{"type", "sphere"}, {"radius", -0.3}}},
      {"sphere_huge", {{"type", "sphere"}, {"radius", 1e7}}},
      {"sphere_no_radius", {{"type", "sphere"}}},
      {"cylinder_zero_height", {{"type", "cylinder"}, {"radius", 0.2}, {"height", 0}}},
      {"cylinder_negative_radius", {{"type", "cylinder"}, {"radius", -0.2}, {"height", 1}}},
      {"capsule_negative_height", {{"type", "capsule"}, {"radius", 0.2}, {"height", -1}}},
      {"capsule_zero_radius", {{"type", "capsule"}, {"radius", 0}, {"height", 1}}},
      {"type_unknown", {{"type", "torus"}, {"radius", 1}}},
      {"type_missing", {{"radius", 1}}},
      {"type_number", {{"type", 3}}},
      {"polytope_empty", {{"type", "polytope"}, {"A", json::array()}, {"b", json::array()}}},
      {"polytope_unbounded", {{"type", "polytope"}, {"A", {{1, 0, 0}}}, {"b", {1}}}},
      {"polytope_infeasible", {{"type", "polytope"}, {"A", {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}}, {"b", {-1, -1, 1, 1, 1, 1}}}},
      {"polytope_flat", {{"type", "polytope"}, {"A", {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}}, {"b", {1, 1, 1, 1, 0, 0}}}},
      {"polytope_zero_rows", {{"type", "polytope"}, {"A", {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}, {"b", {1, 1, 1, 1}}}},
      {"polytope_mismatch", {{"type", "polytope"}, {"A", {{1, 0, 0}, {-1, 0, 0}}}, {"b", {1}}}},
      {"polytope_rows_2", {{"type", "polytope"}, {"A", {{1, 0}, {-1, 0}}}, {"b", {1, 1}}}},
      {"polytope_1001_rows", [] {
         json A = json::array(), b = json::array();
         for (int i = 0; i < 1001; ++i) {
           const double t = i * 0.01;
           A.push_back({std::cos(t), std::sin(t), (i % 2) ? 1.0 : -1.0});
           b.push_back(1);
         }
         return json{{"type", "polytope"}, {"A", A}, {"b", b}};
       }()},
      {"polytope_huge_offsets", {{"type", "polytope"}, {"A", {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}}}, {"b", {1e300, 1e300, 1, 1, 1, 1}}}},
      {"hull_empty", {{"type", "convex_hull"}, {"points", json::array()}}},
      {"hull_one", {{"type", "convex_hull"}, {"points", {{0, 0, 0}}}}},
      {"hull_collinear", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {1, 0, 0}, {2, 0, 0}, {3, 0, 0}}}}},
      {"hull_coplanar", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}}}},
      {"hull_duplicates", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}}},
      {"hull_huge", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {1e7, 0, 0}, {0, 1, 0}, {0, 0, 1}}}}},
      {"hull_tiny", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {1e-12, 0, 0}, {0, 1e-12, 0}, {0, 0, 1e-12}}}}},
      {"hull_100001", [] {
         json p = json::array();
         for (int i = 0; i < 100001; ++i) p.push_back({i % 7, i % 11, i % 13});
         return json{{"type", "convex_hull"}, {"points", p}};
       }()},
      {"quaternion_zero", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"quaternion", {0, 0, 0, 0}}}}}},
      {"quaternion_three", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"quaternion", {1, 0, 0}}}}}},
      {"quaternion_tiny", {{"type", "box"}, {"size", {1, 1, 1}}, {"pose", {{"quaternion", {1e-300, 0, 0, 0}}}}}},
      {"position_huge", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {1e7, 0, 0}}}}}},
      {"position_two", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {1, 0}}}}}},
      {"pose_unknown_key", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"scale", 2}}}}},
      {"weights_negative", {{"type", "box"}, {"size", {1, 1, 1}}, {"weights", {-1, 1, 1, 1, 1, 1}}}},
      {"weights_zero", {{"type", "box"}, {"size", {1, 1, 1}}, {"weights", {0, 0, 0, 0, 0, 0}}}},
      {"weights_length", {{"type", "box"}, {"size", {1, 1, 1}}, {"weights", {1, 1}}}},
      {"weights_on_sphere", {{"type", "sphere"}, {"radius", 0.3}, {"weights", {1}}}},
      {"rho_zero", {{"type", "box"}, {"size", {1, 1, 1}}, {"rho", {{"center", {0, 0, 0}}, {"radius", 0}}}}},
      {"rho_negative", {{"type", "box"}, {"size", {1, 1, 1}}, {"rho", {{"center", {0, 0, 0}}, {"radius", -1}}}}},
      {"rho_too_small", {{"type", "box"}, {"size", {1, 1, 1}}, {"rho", {{"center", {0, 0, 0}}, {"radius", 0.1}}}}},
      {"rho_outside", {{"type", "box"}, {"size", {1, 1, 1}}, {"rho", {{"center", {100, 0, 0}}, {"radius", 1}}}}},
      {"rho_huge", {{"type", "box"}, {"size", {1, 1, 1}}, {"rho", {{"center", {0, 0, 0}}, {"radius", 1e7}}}}},
  };
  for (const auto& [name, shape] : bad_shapes) pair("shape_" + name, shape, far_sphere, nullptr, Expect::client);
  // Params out of range.
  const std::vector<std::pair<std::string, json>> bad_params = {
      {"h_zero", {{"h", 0}}},
      {"h_negative", {{"h", -1}}},
      {"h_huge", {{"h", 1e300}}},
      {"k_0", {{"k", 0}}},
      {"k_1", {{"k", 1}}},
      {"k_13", {{"k", 13}}},
      {"k_fraction", {{"k", 2.5}}},
      {"k_1e10", {{"k", 1e10}}},
      {"k_negative", {{"k", -2}}},
      {"k_2_63", {{"k", 9223372036854775807LL}}},
      {"eps_zero", {{"eps", 0}}},
      {"eps_half", {{"eps", 0.5}}},
      {"eps_negative", {{"eps", -0.1}}},
      {"eps_one", {{"eps", 1}}},
      {"sigma_zero", {{"sigma", 0}}},
      {"sigma_one", {{"sigma", 1}}},
      {"sigma_big", {{"sigma", 1.5}}},
      {"sigma_negative", {{"sigma", -0.5}}},
      {"weight_margin_negative", {{"weight_margin", -1}}},
      {"weight_margin_zero", {{"weight_margin", 0}}},
      {"tol_negative", {{"tol", -1}}},
      {"tol_nan_string", {{"tol", "NaN"}}},
      {"max_iter_negative", {{"max_iter", -1}}},
      {"max_iter_over", {{"max_iter", 1000001}}},
      {"max_iter_fraction", {{"max_iter", 2.5}}},
      {"max_iter_1e300", {{"max_iter", 1e300}}},
      {"max_iter_2_63", {{"max_iter", 9223372036854775807LL}}},
      {"max_iter_2_64", {{"max_iter", 18446744073709551615ULL}}},
      {"solver_unknown", {{"solver", "magic"}}},
      {"solver_number", {{"solver", 1}}},
      {"gradient_string", {{"gradient", "yes"}}},
      {"validate_number", {{"validate", 1}}},
      {"unknown_param", {{"speed", 11}}},
      {"params_array", json::array()},
      {"params_string", "fast"},
  };
  for (const auto& [name, p] : bad_params) pair("params_" + name, sphere, far_sphere, p, Expect::client);
  // Valid but extreme geometry: finite numbers or a 4xx, never a NaN, a null or a 5xx.
  const std::vector<std::tuple<std::string, json, json, json>> edge = {
      {"coincident_spheres", sphere, sphere, nullptr},
      {"coincident_boxes", {{"type", "box"}, {"size", {1, 1, 1}}}, {{"type", "box"}, {"size", {1, 1, 1}}}, nullptr},
      {"touching_boxes", {{"type", "box"}, {"size", {1, 1, 1}}}, {{"type", "box"}, {"size", {1, 1, 1}}, {"pose", {{"position", {1, 0, 0}}}}}, nullptr},
      {"far_apart", sphere, {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {9e5, 0, 0}}}}}, nullptr},
      {"tiny_spheres", {{"type", "sphere"}, {"radius", 1e-6}}, {{"type", "sphere"}, {"radius", 1e-6}, {"pose", {{"position", {1e-5, 0, 0}}}}}, nullptr},
      {"tiny_box", {{"type", "box"}, {"size", {1e-9, 1e-9, 1e-9}}}, far_sphere, nullptr},
      {"thin_box", {{"type", "box"}, {"size", {1, 1, 1e-9}}}, far_sphere, nullptr},
      {"big_sphere", {{"type", "sphere"}, {"radius", 1e5}}, {{"type", "sphere"}, {"radius", 1}, {"pose", {{"position", {0, 0, 2e5}}}}}, nullptr},
      {"nested", {{"type", "sphere"}, {"radius", 1}}, {{"type", "sphere"}, {"radius", 0.1}}, nullptr},
      {"fixed_point_short", sphere, far_sphere, {{"solver", "fixed_point"}, {"max_iter", 3}}},
      {"newton_one_iter", sphere, far_sphere, {{"max_iter", 1}}},
      {"tol_zero", sphere, far_sphere, {{"tol", 0}}},
      {"tol_huge", sphere, far_sphere, {{"tol", 1e300}}},
      {"h_tiny", sphere, far_sphere, {{"h", 1e-12}}},
      {"k_12", sphere, far_sphere, {{"k", 12}}},
      {"eps_tiny", sphere, far_sphere, {{"eps", 1e-300}}},
      {"sigma_tiny", sphere, far_sphere, {{"sigma", 1e-300}}},
      {"weight_margin_huge", {{"type", "box"}, {"size", {1, 1, 1}}}, far_sphere, {{"weight_margin", 1e300}}},
      {"no_validate_big", {{"type", "sphere"}, {"radius", 5}}, {{"type", "sphere"}, {"radius", 5}, {"pose", {{"position", {20, 0, 0}}}}}, {{"validate", false}}},
      {"quaternion_unnormalised", {{"type", "box"}, {"size", {1, 1, 1}}, {"pose", {{"quaternion", {1e5, 1e5, 0, 0}}}}}, far_sphere, nullptr},
      {"cylinder_vs_capsule", {{"type", "cylinder"}, {"radius", 0.1}, {"height", 0.5}}, {{"type", "capsule"}, {"radius", 0.1}, {"height", 0.5}, {"pose", {{"position", {0.5, 0, 0}}}}}, nullptr},
      {"hull_vs_box", {{"type", "convex_hull"}, {"points", {{0, 0, 0}, {0.3, 0, 0}, {0, 0.3, 0}, {0, 0, 0.3}}}}, {{"type", "box"}, {"size", {0.2, 0.2, 0.2}}, {"pose", {{"position", {1, 0, 0}}}}}, nullptr},
  };
  for (const auto& [name, a, b, p] : edge) pair("edge_" + name, a, b, p, Expect::any);
  // Batches.
  auto batch = [&](std::string name, json body, Expect e) {
    out.push_back(api("gap/batch_" + name, "POST", "/api/gap/distance", body.dump(), e));
    out.back().check = no_null(keys);
  };
  batch("empty", {{"pairs", json::array()}}, Expect::any);
  batch("not_array", {{"pairs", {{"a", sphere}}}}, Expect::client);
  batch("missing_b", {{"pairs", {{{"a", sphere}}}}}, Expect::client);
  batch("and_a", {{"pairs", {{{"a", sphere}, {"b", far_sphere}}}}, {"a", sphere}}, Expect::client);
  batch("element_null", {{"pairs", {nullptr}}}, Expect::client);
  batch("2001", {{"pairs", json(std::vector<json>(2001, json{{"a", sphere}, {"b", far_sphere}}))}}, Expect::status);
  out.back().status = 413;
  batch("200_valid", {{"pairs", json(std::vector<json>(200, json{{"a", sphere}, {"b", far_sphere}}))}}, Expect::ok);
  batch("last_bad", {{"pairs", json({json{{"a", sphere}, {"b", far_sphere}}, json{{"a", sphere}, {"b", far_sphere}}, json{{"a", sphere}, {"b", {{"type", "sphere"}, {"radius", -1}}}}})}}, Expect::client);
  batch("heavy_fixed_point", {{"pairs", json(std::vector<json>(50, json{{"a", {{"type", "box"}, {"size", {1, 1, 1}}}}, {"b", {{"type", "box"}, {"size", {1, 1, 1}}, {"pose", {{"position", {1.0001, 0, 0}}}}}}}))}, {"params", {{"solver", "fixed_point"}, {"max_iter", 1000000}, {"tol", 0}}}}, Expect::any);
  out.back().timeout = 90;  // bounded by --max-request-seconds (408)
  // Every leaf of a valid request with a wrong type, extreme numbers, unknown keys.
  const json valid = {{"a", {{"type", "box"}, {"size", {1, 0.6, 0.4}}, {"pose", {{"position", {0, 0, 0}}, {"quaternion", {1, 0, 0, 0}}}}}},
                      {"b", {{"type", "sphere"}, {"radius", 0.3}, {"pose", {{"position", {2, 0, 0}}}}}},
                      {"params", {{"h", 0.1}, {"k", 2}, {"eps", 0.01}, {"sigma", 0.5}, {"weight_margin", 0.01}, {"tol", 1e-10}, {"max_iter", 50}, {"solver", "newton"}, {"gradient", true}, {"validate", true}}}};
  mutate_body(out, "gap/mut", "POST", "/api/gap/distance", valid, true, no_null(keys));
}

// ---------------------------------------------------------------------------------------------
// GAP level sets.

inline void levelset_cases(std::vector<Case>& out) {
  const json shape = {{"type", "box"}, {"size", {1, 0.6, 0.4}}};
  auto ls = [&](std::string name, json extra, Expect e, std::string why = "") {
    json body = {{"shape", shape}, {"format", "json"}, {"grid", {{"resolution", 8}}}};
    for (const auto& [k, v] : extra.items()) body[k] = v;
    out.push_back(api("levelsets/" + name, "POST", "/api/gap/levelsets", body.dump(), e, why));
  };
  ls("valid_small", json::object(), Expect::ok);
  ls("valid_msgpack_plane", {{"format", "msgpack"}, {"plane", {{"resolution", {16, 16}}}}, {"levels", {{"weak", {0.1}}, {"strict", {0.05}}}}}, Expect::ok);
  ls("grid_3", {{"grid", {{"resolution", 3}}}}, Expect::client);
  ls("grid_129", {{"grid", {{"resolution", 129}}}}, Expect::client);
  ls("grid_1e9", {{"grid", {{"resolution", 1e9}}}}, Expect::client);
  ls("grid_fraction", {{"grid", {{"resolution", 8.5}}}}, Expect::client);
  ls("grid_string", {{"grid", {{"resolution", "8"}}}}, Expect::client);
  ls("padding_negative", {{"grid", {{"resolution", 8}, {"padding", -10}}}}, Expect::client);
  ls("padding_huge", {{"grid", {{"resolution", 8}, {"padding", 1e300}}}}, Expect::client,
     "new: padding takes the grid past the coordinate limit that bounds refuse");
  ls("bounds_inverted", {{"grid", {{"resolution", 8}, {"bounds", {{"min", {1, 1, 1}}, {"max", {-1, -1, -1}}}}}}}, Expect::client);
  ls("bounds_empty", {{"grid", {{"resolution", 8}, {"bounds", {{"min", {0, 0, 0}}, {"max", {0, 0, 0}}}}}}}, Expect::client);
  ls("bounds_huge", {{"grid", {{"resolution", 8}, {"bounds", {{"min", {-1e7, 0, 0}}, {"max", {1e7, 1, 1}}}}}}}, Expect::client);
  ls("bounds_min_only", {{"grid", {{"resolution", 8}, {"bounds", {{"min", {0, 0, 0}}}}}}}, Expect::client);
  ls("bounds_far_away", {{"grid", {{"resolution", 8}, {"bounds", {{"min", {1e5, 1e5, 1e5}}, {"max", {1e5 + 1, 1e5 + 1, 1e5 + 1}}}}}}}, Expect::any);
  ls("plane_normal_zero", {{"plane", {{"normal", {0, 0, 0}}, {"resolution", {8, 8}}}}}, Expect::client);
  ls("plane_normal_tiny", {{"plane", {{"normal", {1e-300, 0, 0}}, {"resolution", {8, 8}}}}}, Expect::any);
  ls("plane_size_zero", {{"plane", {{"size", {0, 1}}}}}, Expect::client);
  ls("plane_size_negative", {{"plane", {{"size", {-1, 1}}}}}, Expect::client);
  ls("plane_size_huge", {{"plane", {{"size", {1e300, 1}}}}}, Expect::client);
  ls("plane_size_three", {{"plane", {{"size", {1, 1, 1}}}}}, Expect::client);
  ls("plane_resolution_1", {{"plane", {{"resolution", {1, 1}}}}}, Expect::client);
  ls("plane_resolution_513", {{"plane", {{"resolution", {513, 2}}}}}, Expect::client);
  ls("plane_resolution_fraction", {{"plane", {{"resolution", {2.5, 2}}}}}, Expect::client);
  ls("plane_center_huge", {{"plane", {{"center", {1e7, 0, 0}}, {"resolution", {4, 4}}}}}, Expect::client);
  ls("plane_unknown_key", {{"plane", {{"tilt", 1}}}}, Expect::client);
  ls("levels_17", {{"levels", {{"weak", std::vector<double>(17, 0.1)}}}}, Expect::client);
  ls("levels_huge", {{"levels", {{"weak", {1e300}}, {"strict", {-1e300}}}}}, Expect::any);
  ls("levels_negative", {{"levels", {{"weak", {-1}}}}}, Expect::any);
  ls("levels_string", {{"levels", {{"weak", "0.1"}}}}, Expect::client);
  ls("levels_unknown", {{"levels", {{"medium", {0.1}}}}}, Expect::client);
  ls("format_xml", {{"format", "xml"}}, Expect::client);
  ls("shape_missing", {{"shape", nullptr}}, Expect::client);
  ls("shape_degenerate", {{"shape", {{"type", "box"}, {"size", {0, 0, 0}}}}}, Expect::client);
  ls("params_bad", {{"params", {{"k", 99}}}}, Expect::client);
  ls("unknown_top", {{"zz", 1}}, Expect::client);
  ls("heavy_grid", {{"grid", {{"resolution", 128}}}, {"plane", {{"resolution", {512, 512}}}}}, Expect::any);
  out.back().timeout = 90;
}

// ---------------------------------------------------------------------------------------------
// Kelvin: object creation, σ, levels, queries, iso-surfaces, exports.

inline void kelvin_cases(std::vector<Case>& out) {
  auto create = [&](std::string name, json body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("kelvin/create_" + name, "POST", "/api/kelvin/objects", body.dump(), e, why));
  };
  const json inline_tetra = {{"vertices", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}}};
  create("lx_zero", {{"asset", "cube"}, {"lx", 0}});
  create("lx_negative", {{"asset", "cube"}, {"lx", -0.2}});
  create("lx_tiny", {{"asset", "cube"}, {"lx", 1e-300}});
  create("lx_below_min", {{"asset", "cube"}, {"lx", 0.001}});
  create("lx_over_budget", {{"asset", "cube"}, {"lx", 0.006}});
  create("lx_huge", {{"asset", "cube"}, {"lx", 1e300}}, Expect::client, "9 validation before the job");
  create("lx_string", {{"asset", "cube"}, {"lx", "0.2"}});
  create("lx_missing", {{"asset", "cube"}});
  create("far_radius_zero", {{"asset", "cube"}, {"lx", 0.2}, {"far_radius", 0}}, Expect::client, "9 validation before the job");
  create("far_radius_negative", {{"asset", "cube"}, {"lx", 0.2}, {"far_radius", -1}}, Expect::client, "9 validation before the job");
  create("far_radius_inside", {{"asset", "cube"}, {"lx", 0.2}, {"far_radius", 0.1}}, Expect::client, "9 validation before the job");
  create("far_radius_1e300", {{"asset", "cube"}, {"lx", 0.2}, {"far_radius", 1e300}}, Expect::client, "9 far_radius cast");
  // eq. 23 (grading 0): the graded sizing coarsens the far field, where a far radius costs little.
  create("far_radius_10m", {{"asset", "cube"}, {"lx", 0.2}, {"far_radius", 10}, {"grading", 0}}, Expect::client, "8 budget ignores far_radius");
  create("far_radius_50m", {{"asset", "cube"}, {"lx", 0.05}, {"far_radius", 50}}, Expect::client, "8 budget ignores far_radius");
  create("center_huge", {{"asset", "cube"}, {"lx", 0.2}, {"center", {1e300, 0, 0}}}, Expect::client, "9 validation before the job");
  create("center_outside", {{"asset", "cube"}, {"lx", 0.2}, {"center", {100, 0, 0}}}, Expect::client, "9 validation before the job");
  create("center_two", {{"asset", "cube"}, {"lx", 0.2}, {"center", {0, 0}}});
  create("center_string", {{"asset", "cube"}, {"lx", 0.2}, {"center", "origin"}});
  create("asset_traversal", {{"asset", "../../etc/passwd"}, {"lx", 0.2}});
  create("asset_empty", {{"asset", ""}, {"lx", 0.2}});
  create("asset_unknown", {{"asset", "nothing"}, {"lx", 0.2}});
  create("asset_number", {{"asset", 1}, {"lx", 0.2}});
  create("asset_long", {{"asset", std::string(5000, 'a')}, {"lx", 0.2}});
  create("asset_nul", {{"asset", std::string("cube\0x", 6)}, {"lx", 0.2}});
  create("asset_scenario_name", {{"asset", "scenarios"}, {"lx", 0.2}});
  create("two_sources", {{"asset", "cube"}, {"mesh", inline_tetra}, {"lx", 0.2}});
  create("no_source", {{"lx", 0.2}});
  create("upload_unknown", {{"upload", "0123456789abcdef0123456789abcdef"}, {"lx", 0.2}});
  create("upload_other_session", {{"upload", "{other_upload}"}, {"lx", 0.2}});
  create("upload_number", {{"upload", 7}, {"lx", 0.2}});
  create("mesh_index_negative", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {-1, 2, 3}}}}}, {"lx", 0.2}});
  create("mesh_index_out_of_range", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 4}}}}}, {"lx", 0.2}});
  create("mesh_index_2_32", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 4294967296LL}}}}}, {"lx", 0.2}});
  create("mesh_index_fraction", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 2.5}}}}}, {"lx", 0.2}});
  create("mesh_face_two", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}}}}}, {"lx", 0.2}});
  create("mesh_coord_huge", {{"mesh", {{"vertices", {{0, 0, 0}, {1e7, 0, 0}, {0, 1, 0}, {0, 0, 1}}}, {"faces", inline_tetra["faces"]}}}, {"lx", 0.2}});
  create("mesh_all_same_vertex", {{"mesh", {{"vertices", {{0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}}}, {"faces", inline_tetra["faces"]}}}, {"lx", 0.2}}, Expect::client, "9 validation before the job");
  create("mesh_open", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {0, 3, 2}}}}}, {"lx", 0.2}}, Expect::client, "9 validation before the job");
  create("mesh_degenerate_faces", {{"mesh", {{"vertices", inline_tetra["vertices"]}, {"faces", {{0, 0, 0}, {1, 1, 1}, {2, 2, 2}, {3, 3, 3}}}}}, {"lx", 0.2}}, Expect::client, "9 validation before the job");
  create("mesh_flat", {{"mesh", {{"vertices", {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {1, 1, 0}}}, {"faces", {{0, 1, 2}, {1, 3, 2}, {0, 2, 1}, {1, 2, 3}}}}}, {"lx", 0.2}}, Expect::client, "9 validation before the job");
  create("mesh_vertices_missing", {{"mesh", {{"faces", inline_tetra["faces"]}}}, {"lx", 0.2}});
  create("mesh_string", {{"mesh", "tetra"}, {"lx", 0.2}});
  create("sigma_bad", {{"asset", "cube"}, {"lx", 0.2}, {"sigma", {{"constant", "x"}}}});
  create("sigma_1e300", {{"asset", "cube"}, {"lx", 0.2}, {"sigma", {{"constant", 1e300}}}}, Expect::client, "5 σ range");
  create("levels_17", {{"asset", "cube"}, {"lx", 0.2}, {"levels", std::vector<double>(17, 0.1)}});
  create("unknown_key", {{"asset", "cube"}, {"lx", 0.2}, {"speed", 1}});
  mutate_body(out, "kelvin/create_mut", "POST", "/api/kelvin/objects", {{"asset", "cube"}, {"lx", 0.2}, {"center", {0, 0, 0}}}, false);

  // σ: every form with wrong and extreme values. A wrongly accepted σ is reset after the case.
  const std::string sigma_target = "/api/kelvin/objects/{object}/sigma";
  auto sigma = [&](std::string name, json body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("kelvin/sigma_" + name, "PUT", sigma_target, body.dump(), e, why));
    out.back().check = [](const Reply& r, Ctx& ctx) -> std::string {
      std::string problem;
      if (r.status == 200) {
        // Whatever σ was accepted, a query outside the cube and an iso-surface must stay finite.
        const Reply q = call(ctx, "POST", "/api/kelvin/objects/" + ctx.object + "/query",
                             json{{"points", {{1.2, 0.3, 0.1}, {0, 0, 1.5}}}}.dump(), ctx.session);
        const json j = json::parse(q.body, nullptr, false);
        if (q.status != 200 || !j.is_object() || null_in(j, {"h"})) problem += " after this σ, h outside the cube is null or missing (" + q.body.substr(0, 120) + ");";
        const Reply iso = call(ctx, "GET", "/api/kelvin/objects/" + ctx.object + "/isosurface?level=0.3", "", ctx.session);
        if (iso.status == 200) {
          const json f = json::from_msgpack(iso.body, true, false);
          if (f.is_discarded() || frame_nonfinite(f)) problem += " after this σ, the iso-surface has non-finite floats;";
        }
        call(ctx, "PUT", "/api/kelvin/objects/" + ctx.object + "/sigma", json{{"constant", 0}}.dump(), ctx.session);
      }
      return problem;
    };
  };
  sigma("not_object", json::array());
  sigma("empty", json::object(), Expect::ok);
  sigma("constant_ok", {{"constant", 0.5}}, Expect::ok);
  sigma("constant_negative_ok", {{"constant", -0.5}}, Expect::ok);
  sigma("constant_1e300", {{"constant", 1e300}}, Expect::client, "5 σ range");
  sigma("constant_minus_1e300", {{"constant", -1e300}}, Expect::client, "5 σ range");
  sigma("constant_1e39", {{"constant", 1e39}}, Expect::client, "5 σ range");
  sigma("constant_1e100", {{"constant", 1e100}}, Expect::client, "5 σ range");
  sigma("constant_string", {{"constant", "1"}});
  sigma("per_vertex_empty", {{"per_vertex", json::array()}});
  sigma("per_vertex_wrong_length", {{"per_vertex", {0.1, 0.2, 0.3}}});
  sigma("per_vertex_100k", {{"per_vertex", std::vector<double>(100000, 0.1)}});
  sigma("per_vertex_1e300", {{"per_vertex", std::vector<double>(8, 1e300)}}, Expect::client, "5 σ range");
  sigma("per_vertex_string", {{"per_vertex", "0.1"}});
  sigma("per_vertex_null_entry", {{"per_vertex", {nullptr, 1, 1, 1, 1, 1, 1, 1}}});
  sigma("axis_zero", {{"axis", {{"axis", {0, 0, 0}}}}});
  sigma("axis_missing", {{"axis", {{"d0", 1}}}});
  sigma("axis_width_zero", {{"axis", {{"axis", {0, 0, 1}}, {"width", 0}}}});
  sigma("axis_width_negative", {{"axis", {{"axis", {0, 0, 1}}, {"width", -1}}}});
  sigma("axis_sigma_nom_1e300", {{"axis", {{"axis", {0, 0, 1}}, {"sigma_nom", 1e300}}}}, Expect::client, "5 σ range");
  sigma("axis_huge_axis", {{"axis", {{"axis", {1e300, 0, 0}}}}}, Expect::any);  // a direction
  sigma("axis_tiny_axis", {{"axis", {{"axis", {1e-300, 0, 0}}}}});
  sigma("axis_1000", {{"axis", std::vector<json>(1000, json{{"axis", {0, 0, 1}}})}}, Expect::any);
  sigma("axis_unknown", {{"axis", {{"axis", {0, 0, 1}}, {"tilt", 1}}}});
  sigma("brush_radius_zero", {{"brushes", {{{"center", {0, 0, 0}}, {"radius", 0}, {"value", 1}}}}}, Expect::client, "new: brush radius 0 accepted");
  sigma("brush_radius_negative", {{"brushes", {{{"center", {0, 0, 0}}, {"radius", -1}, {"value", 1}}}}});
  sigma("brush_value_1e300", {{"brushes", {{{"center", {0, 0, 0}}, {"radius", 1}, {"value", 1e300}}}}}, Expect::client, "5 σ range");
  sigma("brush_falloff_negative", {{"brushes", {{{"center", {0, 0, 0}}, {"radius", 1}, {"value", 1}, {"falloff", -1}}}}});
  sigma("brush_center_huge", {{"brushes", {{{"center", {1e300, 0, 0}}, {"radius", 1}, {"value", 1}}}}}, Expect::client,
        "new: brush center beyond the coordinate limit accepted");
  sigma("brush_missing_value", {{"brushes", {{{"center", {0, 0, 0}}, {"radius", 1}}}}});
  sigma("brushes_10000", {{"brushes", std::vector<json>(10000, json{{"center", {0, 0, 0}}, {"radius", 0.1}, {"value", 0.01}})}}, Expect::any);
  sigma("brushes_not_array", {{"brushes", {{"center", {0, 0, 0}}}}});
  sigma("unknown_key", {{"constant", 0.1}, {"bogus", 1}});
  sigma("sum_overflow", {{"constant", 1e308}, {"axis", {{"axis", {0, 0, 1}}, {"sigma_nom", 1e308}}}}, Expect::client, "5 σ range");
  out.push_back(api("kelvin/sigma_other_session_object", "PUT", "/api/kelvin/objects/{other_object}/sigma", json{{"constant", 0.5}}.dump(), Expect::status));
  out.back().status = 404;

  // Levels.
  const std::string lv = "/api/kelvin/objects/{object}/levels";
  auto levels = [&](std::string name, json body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("kelvin/levels_" + name, "PUT", lv, body.dump(), e, why));
  };
  levels("ok", {{"levels", {0.1, 0.3}}}, Expect::ok);
  levels("empty", {{"levels", json::array()}}, Expect::ok);
  levels("17", {{"levels", std::vector<double>(17, 0.1)}});
  levels("huge", {{"levels", {1e300}}}, Expect::any);
  levels("string", {{"levels", "0.1"}});
  levels("nested", {{"levels", {{0.1}}}});
  levels("missing", json::object());
  levels("unknown_key", {{"levels", {0.1}}, {"bogus", 1}}, Expect::client, "13 unknown keys");
  levels("reset", {{"levels", json::array()}}, Expect::ok);

  // Queries.
  const std::string qt = "/api/kelvin/objects/{object}/query";
  auto q = [&](std::string name, json body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("kelvin/query_" + name, "POST", qt, body.dump(), e, why));
  };
  q("outside_ok", {{"points", {{1.2, 0, 0}, {0, 1.3, 0.2}}}}, Expect::ok);
  out.back().check = no_null({"h"});
  q("inside_ok", {{"points", {{0, 0, 0}}}}, Expect::ok);
  q("far_point", {{"points", {{1e5, 0, 0}}}}, Expect::any);
  q("huge_point", {{"points", {{1e300, 0, 0}}}}, Expect::any);
  q("empty", {{"points", json::array()}}, Expect::any);
  q("point_two", {{"points", {{1, 0}}}});
  q("point_four", {{"points", {{1, 0, 0, 0}}}});
  q("point_string", {{"points", {{"1", 0, 0}}}});
  q("point_null", {{"points", {nullptr}}});
  q("points_object", {{"points", {{"x", 1}}}});
  q("points_missing", json::object());
  q("points_100001", {{"points", std::vector<json>(100001, json{1.2, 0, 0})}});
  q("points_20000_valid", {{"points", std::vector<json>(20000, json{1.2, 0.1, 0})}}, Expect::ok);
  out.back().check = no_null({"h"});
  q("unknown_key", {{"points", {{1.2, 0, 0}}}, {"bogus", 1}}, Expect::client, "13 unknown keys");
  out.push_back(api("kelvin/query_other_session_object", "POST", "/api/kelvin/objects/{other_object}/query", json{{"points", {{1, 0, 0}}}}.dump(), Expect::status));
  out.back().status = 404;

  // Iso-surfaces and exports: the level from the query string.
  for (const std::string kind : {"isosurface", "export"}) {
    auto g = [&](std::string name, std::string query, Expect e = Expect::client, std::string why = "") {
      out.push_back(api("kelvin/" + kind + "_" + name, "GET", "/api/kelvin/objects/{object}/" + kind + query, "", e, why));
    };
    g("ok", "?level=0.3", Expect::ok);
    g("no_level", "");
    g("level_empty", "?level=");
    g("level_text", "?level=abc");
    g("level_nan", "?level=nan");
    g("level_NaN", "?level=NaN");
    g("level_inf", "?level=inf");
    g("level_minus_inf", "?level=-inf");
    g("level_1e999", "?level=1e999");
    g("level_hex", "?level=0x10", Expect::any);  // strtod reads 16: then a level like any other
    g("level_trailing", "?level=0.3abc");
    g("level_space", "?level=%200.3", Expect::any);
    g("level_nul", "?level=0.3%00");
    g("level_repeated", "?level=0.3&level=0.4");
    g("level_never_taken_low", "?level=-1000", Expect::client, "4 empty_isosurface");
    g("level_never_taken_high", "?level=1e300", Expect::client, "4 empty_isosurface");
    g("level_denormal", "?level=4.9e-324", Expect::any);
    g("level_long", "?level=" + std::string(5000, '1'), Expect::client);
    if (kind == "export") {
      g("format_exe", "?level=0.3&format=exe");
      g("format_repeated", "?level=0.3&format=stl&format=obj");
      g("format_traversal", "?level=0.3&format=../../x");
      for (const std::string f : {"stl", "obj", "ply", "glb"}) g("format_" + f, "?level=0.3&format=" + f, Expect::ok);
    }
  }
  out.push_back(api("kelvin/surface_ok", "GET", "/api/kelvin/objects/{object}/surface", "", Expect::ok));
  out.push_back(api("kelvin/object_get_ok", "GET", "/api/kelvin/objects/{object}", "", Expect::ok));
}

// ---------------------------------------------------------------------------------------------
// CBF rollouts.

inline void cbf_cases(std::vector<Case>& out) {
  auto roll = [&](std::string name, json body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("cbf/" + name, "POST", "/api/cbf/rollouts", body.dump(), e, why));
  };
  const json shortp = {{"duration", 0.03}};
  roll("scenario_traversal", {{"scenario", "../../etc/passwd"}});
  roll("scenario_empty", {{"scenario", ""}});
  roll("scenario_long", {{"scenario", std::string(100, 'a')}});
  roll("scenario_unknown", {{"scenario", "nowhere"}});
  roll("scenario_number", {{"scenario", 1}});
  roll("scenario_missing", {{"metric", "gap"}});
  roll("metric_unknown", {{"scenario", "corridor"}, {"metric", "manhattan"}, {"params", shortp}});
  roll("params_unknown", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"speed", 1}}}});
  roll("dt_zero", {{"scenario", "corridor"}, {"params", {{"dt", 0}, {"duration", 0.03}}}});
  roll("dt_negative", {{"scenario", "corridor"}, {"params", {{"dt", -0.01}, {"duration", 0.03}}}});
  roll("dt_tiny", {{"scenario", "corridor"}, {"params", {{"dt", 1e-300}, {"duration", 1}}}});
  roll("duration_huge", {{"scenario", "corridor"}, {"params", {{"duration", 1e300}}}});
  roll("duration_negative", {{"scenario", "corridor"}, {"params", {{"duration", -1}}}});
  roll("duration_over_steps", {{"scenario", "corridor"}, {"params", {{"duration", 100000}, {"dt", 0.001}}}});
  roll("q0_short", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"q0", {0, 0, 0}}}}});
  roll("q0_huge", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"q0", {1e300, 0, 0, 0, 0, 0, 0}}}}});
  roll("task_gain_negative", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"task_gain", -1}}}});
  roll("eta_zero", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"eta", 0}}}}, Expect::any);
  roll("slack_weight_negative", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"slack_weight", -1}}}});
  roll("margins_gap_obstacle_negative", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"margins", {{"gap", {{"obstacle", -1}}}}}}}},
       Expect::client, "13 CBF margin field path");
  out.back().check = field_is("params.margins.gap.obstacle");
  roll("margins_unknown", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"margins", {{"gap", {{"wall", 1}}}}}}}});
  roll("gap_k_99", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"gap", {{"k", 99}}}}}});
  roll("gap_max_iter_huge", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"gap", {{"max_iter", 1e300}}}}}});
  roll("gap_unknown", {{"scenario", "corridor"}, {"params", {{"duration", 0.03}, {"gap", {{"validate", false}}}}}});
  roll("stream_batch_zero", {{"scenario", "corridor"}, {"params", shortp}, {"stream", {{"batch_steps", 0}}}});
  roll("stream_batch_huge", {{"scenario", "corridor"}, {"params", shortp}, {"stream", {{"batch_steps", 1e9}}}});
  roll("stream_batch_fraction", {{"scenario", "corridor"}, {"params", shortp}, {"stream", {{"batch_steps", 2.5}}}});
  roll("stream_unknown", {{"scenario", "corridor"}, {"params", shortp}, {"stream", {{"fast", true}}}});
  roll("inline_no_obstacles_key", {{"scenario", {{"target", {{"position", {0.5, 0, 0.5}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  roll("inline_1001_obstacles", {{"scenario", {{"obstacles", std::vector<json>(1001, json{{"shape", {{"type", "sphere"}, {"radius", 0.1}}}})}, {"target", {{"position", {0.5, 0, 0.5}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  roll("inline_target_quaternion_zero", {{"scenario", {{"obstacles", json::array()}, {"target", {{"position", {0.5, 0, 0.5}}, {"quaternion", {0, 0, 0, 0}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  roll("inline_robot_other", {{"scenario", {{"robot", "ur5"}, {"obstacles", json::array()}, {"target", {{"position", {0.5, 0, 0.5}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  roll("inline_obstacle_degenerate", {{"scenario", {{"obstacles", {{{"shape", {{"type", "box"}, {"size", {0, 0, 0}}}}}}}, {"target", {{"position", {0.5, 0, 0.5}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  roll("inline_target_huge", {{"scenario", {{"obstacles", json::array()}, {"target", {{"position", {1e300, 0, 0}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}}}});
  // Kelvin fields in an inline scenario: refused before any job prepares them.
  const json wrench = {{"name", "w"}, {"mesh", {{"asset", "wrench"}}}, {"lx", 0.002}, {"center", {0.015, 0, 0}}, {"delta", 0.2}};
  const json inline_base = {{"obstacles", json::array()}, {"target", {{"position", {0.5, 0, 0.5}}}}, {"q0", {0, 0, 0, -1.5, 0, 1.5, 0}}, {"control_points", {{{"link", "panda_link7"}, {"point", {0, 0, 0}}}}}};
  auto with_field = [&](const json& field, const json& extra = json::object()) {
    json sc = inline_base;
    sc["fields"] = json::array({field});
    for (const auto& [k, v] : extra.items()) sc[k] = v;
    return json{{"scenario", sc}, {"metric", "euclidean"}, {"params", shortp}};
  };
  json f = wrench;
  f["mesh"] = {{"path", "/etc/passwd"}};
  roll("field_mesh_path", with_field(f));
  out.back().check = field_is("scenario.fields[0].mesh.path");
  f = wrench;
  f["mesh"] = {{"asset", "../../etc/passwd"}};
  roll("field_asset_traversal", with_field(f));
  f = wrench;
  f["lx"] = 1e-300;
  roll("field_lx_tiny", with_field(f));
  out.back().check = field_is("scenario.fields[0].lx");
  f = wrench;
  f["far_radius"] = 1e300;
  roll("field_far_radius_huge", with_field(f));
  f = wrench;
  f["sigma"] = {{"per_vertex", std::vector<double>(3, 1.0)}};
  roll("field_per_vertex_short", with_field(f));
  roll("field_nine", with_field(wrench, {{"fields", std::vector<json>(9, wrench)}}));
  roll("field_sample_huge", with_field(wrench, {{"control_points", {{{"link", "panda_link7"}, {"sample", 1e9}}}}}));
  roll("field_point_unknown_link", with_field(wrench, {{"control_points", {{{"link", "../panda_link7"}, {"point", {0, 0, 0}}}}}}));
  roll("field_params_sigma_count", {{"scenario", "wrench_grasp"}, {"params", {{"duration", 0.03}, {"fields", json::array({json::object(), json::object()})}}}});
  roll("valid_short", {{"scenario", "corridor"}, {"params", shortp}}, Expect::ok);
  mutate_body(out, "cbf/mut", "POST", "/api/cbf/rollouts",
              {{"scenario", "corridor"}, {"metric", "euclidean"}, {"params", {{"duration", 0.03}, {"dt", 0.01}, {"eta", 0.5}, {"goal_tolerance", 0.001}, {"self_collision", false}}}},
              false);
  auto get = [&](std::string name, std::string target, Expect e = Expect::client) {
    out.push_back(api("cbf/" + name, "GET", target, "", e));
  };
  get("scenario_get_ok", "/api/cbf/scenarios/corridor", Expect::ok);
  get("scenario_get_traversal", "/api/cbf/scenarios/..%2F..%2Fetc%2Fpasswd");
  get("scenario_get_dots", "/api/cbf/scenarios/..");
  get("scenario_get_long", "/api/cbf/scenarios/" + std::string(3000, 'a'));
  get("scenario_get_nul", "/api/cbf/scenarios/corridor%00");
  get("frames_ok", "/api/cbf/rollouts/{rollout}/frames", Expect::ok);
  get("frames_from_negative", "/api/cbf/rollouts/{rollout}/frames?from=-1");
  get("frames_from_text", "/api/cbf/rollouts/{rollout}/frames?from=abc");
  get("frames_from_huge", "/api/cbf/rollouts/{rollout}/frames?from=1e300", Expect::any);
  get("frames_from_2_64", "/api/cbf/rollouts/{rollout}/frames?from=18446744073709551616", Expect::any);
  get("frames_count_huge", "/api/cbf/rollouts/{rollout}/frames?count=1000000000");
  get("frames_count_zero", "/api/cbf/rollouts/{rollout}/frames?count=0", Expect::any);
  get("frames_count_fraction", "/api/cbf/rollouts/{rollout}/frames?count=2.5");
  get("record_ok", "/api/cbf/rollouts/{rollout}/record", Expect::ok);
  get("fields_none", "/api/cbf/rollouts/{rollout}/fields");  // a corridor rollout: 404 no_fields
  get("fields_levels_text", "/api/cbf/rollouts/{rollout}/fields?levels=abc");
  get("fields_levels_nan", "/api/cbf/rollouts/{rollout}/fields?levels=nan");
  get("fields_levels_inf", "/api/cbf/rollouts/{rollout}/fields?levels=1e999");
  get("fields_levels_empty", "/api/cbf/rollouts/{rollout}/fields?levels=,,");
  get("fields_levels_many", "/api/cbf/rollouts/{rollout}/fields?levels=" + std::string(20000, '1'));
  get("fields_levels_twice", "/api/cbf/rollouts/{rollout}/fields?levels=0&levels=1");
  get("rollout_unknown", "/api/cbf/rollouts/ffffffffffffffffffffffffffffffff");
}

// ---------------------------------------------------------------------------------------------
// Robots (POST /api/robot/distances): built-in names, URDF texts an XML parser would choke on,
// meshes of other sessions, configurations and obstacles out of range, limits.

// A 200 answer's arrays hold numbers only, at any depth (no null for a NaN or an infinity).
inline bool null_anywhere(const json& j) {
  if (j.is_null()) return true;
  if (j.is_array() || j.is_object())
    for (const auto& v : j)
      if (null_anywhere(v)) return true;
  return false;
}

inline std::function<std::string(const Reply&, Ctx&)> robot_numbers() {
  return [](const Reply& r, Ctx&) -> std::string {
    if (r.status != 200) return "";
    const json j = json::parse(r.body, nullptr, false);
    if (j.is_discarded()) return " answer is not JSON;";
    for (const char* k : {"distance", "jacobian", "witness_robot", "witness_obstacle"})
      if (j.contains(k) && null_anywhere(j[k])) return std::string(" null in ") + k + ";";
    return "";
  };
}

inline void robot_cases(std::vector<Case>& out) {
  const json q = {1.0582, -1.3811, 0.3629, -1.9647, -0.959, 1.4881, -0.1534};
  const json wall = {{"type", "box"}, {"name", "wall"}, {"size", {0.32, 0.08, 0.92}}, {"pose", {{"position", {0.52, 0.19, 0.48}}}}};
  const json valid = {{"robot", "panda"}, {"q", {q, q}}, {"obstacles", json::array({wall})}, {"metric", "gap"}, {"pairs", "both"}, {"params", {{"tol", 1e-10}, {"max_iter", 50}}}};
  auto post = [&](std::string name, const json& body, Expect e = Expect::client, std::string why = "") {
    out.push_back(api("robot/" + name, "POST", "/api/robot/distances", body.dump(), e, why));
    out.back().check = robot_numbers();
  };
  const auto with = [&](const std::string& key, const json& value) {
    json b = valid;
    b[key] = value;
    return b;
  };
  post("valid", valid, Expect::ok);
  post("valid_euclidean", with("metric", "euclidean"), Expect::ok);
  mutate_body(out, "robot/mut", "POST", "/api/robot/distances", valid, true, robot_numbers());
  // Built-in names that could leave the robots' folder or are not robots.
  for (const char* name : {"../robots/panda", "..", "/etc/passwd", "panda.urdf", "panda%00", "", "PANDA", "corridor"})
    post(std::string("name_") + name, with("robot", name));
  post("name_long", with("robot", std::string(5000, 'a')));
  // Configurations: one number, none, NaN-like text, past the coordinate bound, too many.
  post("q_scalar", with("q", 0.5));
  post("q_empty_rows", with("q", json::array({json::array()})));
  post("q_ragged", with("q", json::array({q, json::array({0, 0})})));
  post("q_huge", with("q", json::array({{1e300, 0, 0, 0, 0, 0, 0}})));
  post("q_10001", with("q", std::vector<json>(10001, q)), Expect::status, "413 past max_robot_configurations");
  out.back().status = 413;
  post("q_evaluations", with("q", std::vector<json>(5000, q)), Expect::status, "413 past max_robot_pair_evaluations");
  out.back().status = 413;
  post("obstacles_257", with("obstacles", std::vector<json>(257, json{{"type", "sphere"}, {"radius", 0.1}})), Expect::status);
  out.back().status = 413;
  post("obstacle_name_twice", with("obstacles", json::array({wall, wall})));
  post("obstacle_name_long", with("obstacles", json::array({json{{"type", "sphere"}, {"radius", 0.1}, {"name", std::string(100, 'x')}}})));
  post("pairs_allow_unknown_link", with("pairs", {{"self", true}, {"allow", json::array({json::array({"panda_link1", "../x"})})}}));
  post("pairs_allow_100k", with("pairs", {{"self", true}, {"allow", std::vector<json>(100000, json::array({"panda_link1", "panda_link2"}))}}));
  post("params_fixed_point", with("params", {{"solver", "fixed_point"}, {"max_iter", 1000}}), Expect::ok);
  post("params_max_iter_budget", with("params", {{"max_iter", 2000000}}), Expect::status);
  out.back().status = 422;
  // URDF texts: what TinyXML recurses or loops on, entities, huge and broken documents.
  const auto urdf = [&](std::string name, const std::string& text, Expect e = Expect::client) {
    post("urdf_" + name, with("robot", {{"urdf", text}}), e);
  };
  const std::string chain = "<robot name=\"r\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint><link name=\"b\"><collision><geometry><sphere radius=\"0.1\"/></geometry></collision></link></robot>";
  urdf("valid_no_q", chain);  // q has 7 numbers, the robot 1 joint
  urdf("nested_300k", "<robot name=\"r\">" + repeat("<a>", 300000) + "</robot>");
  urdf("nested_100k_closed", "<robot name=\"r\">" + repeat("<a>", 100000) + repeat("</a>", 100000) + "</robot>");
  urdf("attributes_70k", "<robot name=\"r\"><link name=\"l\" " + repeat("a=\"\" ", 70000) + "/></robot>");
  urdf("links_20k", "<robot name=\"r\">" + repeat("<link name=\"l\"/>", 20000) + "</robot>");
  urdf("cdata", "<robot name=\"r\"><![CDATA[" + repeat("<a>", 1000) + "]]></robot>");
  urdf("doctype_entities", "<!DOCTYPE r [<!ENTITY a \"aaaaaaaaaa\"><!ENTITY b \"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;\">]><robot name=\"&b;\"/>");
  urdf("unquoted", "<robot name=r><link name=a/></robot>");
  urdf("quote_hides_tags", "<robot name=\"r\"><link name=x\"" + repeat("<a>", 1000) + "\"/></robot>");
  urdf("pi_with_gt", "<?xml version=\"1.0\" > " + repeat("<a>", 1000) + "?><robot name=\"r\"/>");
  urdf("unclosed_comment", "<robot name=\"r\"><!-- " + repeat("<a>", 1000));
  urdf("empty", "");
  urdf("one_mib_plus", std::string((std::size_t{1} << 20) + 1, ' '));
  urdf("bad_numbers", "<robot name=\"r\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><origin xyz=\"1e400 nan 0\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint><link name=\"b\"/></robot>");
  urdf("cycle", "<robot name=\"r\"><link name=\"a\"/><link name=\"b\"/><joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint><joint name=\"k\" type=\"revolute\"><parent link=\"b\"/><child link=\"a\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint></robot>");
  json one = with("robot", {{"urdf", chain}});
  one["q"] = json::array({0.5});
  post("urdf_chain_ok", one, Expect::ok);
  // Meshes: another session's upload, an unknown id, absolute paths and traversal as keys.
  const std::string mesh_urdf = "<robot name=\"r\"><link name=\"a\"/><joint name=\"j\" type=\"revolute\"><parent link=\"a\"/><child link=\"b\"/><limit lower=\"-1\" upper=\"1\" effort=\"1\" velocity=\"1\"/></joint><link name=\"b\"><collision><geometry><mesh filename=\"/etc/passwd\"/></geometry></collision></link></robot>";
  one["robot"] = {{"urdf", mesh_urdf}, {"meshes", {{"/etc/passwd", "{other_upload}"}}}};
  post("mesh_other_sessions_upload", one, Expect::status);
  out.back().status = 404;
  one["robot"] = {{"urdf", mesh_urdf}};
  post("mesh_absolute_path_not_read", one);
  one["robot"] = {{"urdf", mesh_urdf}, {"meshes", {{"/etc/passwd", "0123"}, {"../../x", "0123"}}}};
  post("mesh_unknown_upload", one, Expect::status);
  out.back().status = 404;
  out.push_back(api("robot/robots_list", "GET", "/api/robot/robots", "", Expect::ok));
}

// ---------------------------------------------------------------------------------------------
// Uploads in every accepted format, generated with broken headers, counts and indices.

inline void upload_cases(std::vector<Case>& out) {
  auto up = [&](std::string name, std::string format, std::string bytes, Expect e = Expect::client, std::string why = "") {
    Case c = make(
        "upload/" + format + "_" + name, [format, bytes](Ctx& ctx) {
          // A session holds at most max_uploads_per_session uploads: rotate before the cap.
          if (ctx.upload_session.empty() || ctx.uploads_in_session >= 6) {
            if (!ctx.upload_session.empty()) call(ctx, "DELETE", "/api/session", "", ctx.upload_session);
            ctx.upload_session = make_session(ctx);
            ctx.uploads_in_session = 0;
          }
          ++ctx.uploads_in_session;
          return http("POST", "/api/kelvin/uploads?format=" + format, bytes, ctx.upload_session);
        },
        e, why);
    c.timeout = 30;
    out.push_back(c);
  };
  const std::vector<float> tv = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  const std::vector<std::vector<std::int64_t>> tf = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  const std::vector<std::array<float, 9>> tstl = {{0, 0, 0, 0, 1, 0, 1, 0, 0}, {0, 0, 0, 1, 0, 0, 0, 0, 1}, {0, 0, 0, 0, 0, 1, 0, 1, 0}, {1, 0, 0, 0, 1, 0, 0, 0, 1}};
  const float qnan = std::numeric_limits<float>::quiet_NaN(), pinf = std::numeric_limits<float>::infinity();

  // STL.
  up("binary_valid", "stl", binary_stl(4, tstl), Expect::ok);
  up("binary_count_huge", "stl", binary_stl(0xFFFFFFFFu, tstl));
  up("binary_count_zero", "stl", binary_stl(0, tstl));
  up("binary_count_short", "stl", binary_stl(1, tstl));
  up("binary_count_zero_empty", "stl", binary_stl(0, {}));
  up("binary_truncated_header", "stl", std::string(40, 'x'));
  up("binary_84_bytes", "stl", binary_stl(0, {}));
  up("binary_nan", "stl", binary_stl(4, {{qnan, 0, 0, 0, 1, 0, 1, 0, 0}, tstl[1], tstl[2], tstl[3]}), Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("binary_inf", "stl", binary_stl(4, {{pinf, 0, 0, 0, 1, 0, 1, 0, 0}, tstl[1], tstl[2], tstl[3]}), Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("binary_huge_coords", "stl", binary_stl(4, {{1e30f, 0, 0, 0, 1, 0, 1, 0, 0}, tstl[1], tstl[2], tstl[3]}), Expect::client,
     "new: uploads skip the coordinate limit inline meshes have");
  up("binary_degenerate", "stl", binary_stl(4, std::vector<std::array<float, 9>>(4, {0, 0, 0, 0, 0, 0, 0, 0, 0})), Expect::any);  // refused at upload or at creation
  up("binary_header_solid", "stl", binary_stl(4, tstl, "solid trick"), Expect::ok);
  up("binary_over_triangles", "stl", binary_stl(200001, {}) + std::string(200001 * 50, '\0'));
  up(
      "ascii_valid", "stl", "solid t\n" + [&] {
        std::string s;
        for (const auto& t : tstl) {
          s += "facet normal 0 0 0\nouter loop\n";
          for (int k = 0; k < 3; ++k) s += "vertex " + std::to_string(t[3 * k]) + " " + std::to_string(t[3 * k + 1]) + " " + std::to_string(t[3 * k + 2]) + "\n";
          s += "endloop\nendfacet\n";
        }
        return s;
      }() + "endsolid t\n",
      Expect::ok);
  up("ascii_only_solid", "stl", "solid\n");
  up("ascii_no_vertices", "stl", "solid t\nfacet normal 0 0 1\nouter loop\nendloop\nendfacet\nendsolid t\n");
  up("ascii_two_vertices", "stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid t\n");
  up("ascii_nan", "stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex nan 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("ascii_1e999", "stl", "solid t\nfacet normal 0 0 1\nouter loop\nvertex 1e999 0 0\nvertex 1 0 0\nvertex 0 1 0\nendloop\nendfacet\nendsolid t\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("ascii_text_garbage", "stl", "solid " + repeat("vertex vertex facet ", 5000));
  up("ascii_long_line", "stl", "solid t\nfacet normal " + std::string(1 << 20, '1') + "\n");
  up("not_stl", "stl", "hello world, this is not a mesh");
  up("binary_zeros_1k", "stl", std::string(1000, '\0'));

  // OBJ.
  up("valid", "obj", kTetraObj, Expect::ok);
  up("index_zero", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 0 1 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  up("index_out_of_range", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 99\n");
  up("index_huge", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4294967297\n");
  up("index_negative_out", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf -9 -8 -7\n");
  up("index_negative_ok", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf -4 -2 -3\nf -4 -3 -1\nf -4 -1 -2\nf -3 -2 -1\n", Expect::ok);
  up("texture_index_out", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvt 0 0\nf 1/9 3/9 2/9\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", Expect::any);  // positions are right
  up("normal_index_out", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nf 1//7 3//7 2//7\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", Expect::any);
  up("face_two_vertices", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 2\n");
  up("face_300_vertices", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf " + repeat("1 2 3 4 ", 75) + "\n", Expect::any);
  up("only_vertices", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n");
  up("no_vertices", "obj", "f 1 2 3\n");
  up("vertex_nan", "obj", "v nan 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("vertex_inf", "obj", "v inf 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("vertex_1e999", "obj", "v 1e999 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("vertex_missing_coords", "obj", "v 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n");
  up("mtllib_traversal", "obj", std::string("mtllib ../../../../etc/passwd\nusemtl x\n") + kTetraObj, Expect::any);
  up("mtllib_dev_zero", "obj", std::string("mtllib /dev/zero\n") + kTetraObj, Expect::any);
  up("long_line", "obj", "v " + std::string(1 << 20, '1') + " 0 0\n" + kTetraObj, Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("no_newline", "obj", "v 0 0 0 v 1 0 0 f 1 2 3");
  up("binary_junk", "obj", std::string("\x00\xff\x10\x80v f\x00", 8) + std::string(500, '\x01'));
  up("deep_groups", "obj", repeat("g a\no b\n", 5000) + kTetraObj, Expect::any);
  up("faces_200001", "obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n" + repeat("f 1 2 3\n", 200001));

  // PLY.
  const auto ply_ascii = [](const std::string& vc, const std::string& fc, const std::string& body) {
    return "ply\nformat ascii 1.0\nelement vertex " + vc + "\nproperty float x\nproperty float y\nproperty float z\nelement face " + fc +
           "\nproperty list uchar int vertex_indices\nend_header\n" + body;
  };
  const std::string tetra_ascii = "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n";
  up("ascii_valid", "ply", ply_ascii("4", "4", tetra_ascii), Expect::ok);
  up("binary_valid", "ply", ply_binary("4", "4", tv, tf), Expect::ok);
  up("ascii_index_negative", "ply", ply_ascii("4", "4", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 -1 2 3\n"), Expect::client, "6 importer SIGSEGV");
  up("ascii_index_out_of_range", "ply", ply_ascii("4", "4", "0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 99\n"), Expect::client, "6 importer SIGSEGV");
  up("binary_index_negative", "ply", ply_binary("4", "4", tv, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {-5, 2, 3}}), Expect::client, "6 importer SIGSEGV");
  up("binary_index_out_of_range", "ply", ply_binary("4", "4", tv, {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 1000000}}), Expect::client, "6 importer SIGSEGV");
  up("binary_list_count_255", "ply", ply_binary("4", "4", tv, tf, "uchar", "int", 255), Expect::client, "6 importer SIGSEGV");
  up("binary_list_count_0", "ply", ply_binary("4", "4", tv, {{}, {}, {}, {}}), Expect::client, "6/7 importer hang");
  up("binary_list_count_uint_huge", "ply", ply_binary("4", "1", tv, {{0, 1, 2}}, "uint", "int", 0x7fffffff), Expect::client, "7 declared counts");
  up("vertex_count_4294967295", "ply", ply_binary("4294967295", "4", tv, tf), Expect::client, "7 declared counts");
  up("vertex_count_1e9", "ply", ply_binary("1000000000", "4", tv, tf), Expect::client, "7 declared counts");
  up("face_count_4294967295", "ply", ply_binary("4", "4294967295", tv, tf), Expect::client, "7 declared counts");
  up("vertex_count_negative", "ply", ply_binary("-4", "4", tv, tf));
  up("vertex_count_text", "ply", ply_binary("four", "4", tv, tf));
  up("ascii_vertex_count_1e9", "ply", ply_ascii("1000000000", "4", tetra_ascii), Expect::client, "7 declared counts");
  up("truncated_data", "ply", ply_binary("4", "4", tv, tf).substr(0, 250), Expect::client, "6 importer crash");
  up("no_end_header", "ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\n", Expect::client, "6/7 importer hang");
  up(
      "big_endian", "ply", [&] {
        std::string s = ply_binary("4", "4", tv, tf);
        s.replace(s.find("binary_little_endian"), 20, "binary_big_endian");
        return s;
      }(),
      Expect::any, "6 importer crash");
  up("format_unknown", "ply", "ply\nformat weird 9.0\nelement vertex 0\nend_header\n");
  up("ushort_index", "ply", ply_binary("4", "4", tv, tf, "uchar", "ushort"), Expect::any);
  up("face_before_vertex", "ply", "ply\nformat ascii 1.0\nelement face 4\nproperty list uchar int vertex_indices\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nend_header\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n", Expect::any);
  up("no_faces", "ply", "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n");
  up("property_list_list", "ply", "ply\nformat ascii 1.0\nelement vertex 4\nproperty list uchar float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n1 0 0 0\n1 1 0 0\n1 0 1 0\n1 0 0 1\n3 0 1 2\n", Expect::any);
  up("ascii_nan", "ply", ply_ascii("4", "4", "nan 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n"), Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("header_only_magic", "ply", "ply\n");
  up("many_elements", "ply", "ply\nformat ascii 1.0\n" + repeat("element junk 0\nproperty float a\n", 5000) + "end_header\n");

  // OFF.
  up("valid", "off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", Expect::ok);
  up("16_bytes", "off", "OFF\n3 1 0\n0 0 0", Expect::client, "6 importer SIGABRT");
  up("vertices_1e9", "off", "OFF\n1000000000 1 0\n0 0 0\n", Expect::client, "7 declared counts");
  up("faces_1e9", "off", "OFF\n4 1000000000 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n", Expect::client, "7 declared counts");
  up("counts_negative", "off", "OFF\n-4 -4 0\n0 0 0\n");
  up("counts_text", "off", "OFF\nfour four 0\n");
  up("index_out_of_range", "off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 77\n", Expect::client, "6 importer SIGSEGV");
  up("index_negative", "off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 -1 2 3\n", Expect::client, "6 importer SIGSEGV");
  // A face listing one cycle r times over is that cycle (real OBJ exports have them, issue 36):
  // 85 × (0 1 2) is one triangle, and one triangle is an open sheet. 63 × (0 1 2 3) + (0 1 2) is no
  // cycle: a 255-corner face that pinches (and over the 3D fallback's corner bound).
  up("face_255_vertices_one_cycle", "off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n255 " + repeat("0 1 2 ", 85) + "\n", Expect::ok);
  up("face_255_vertices", "off", "OFF\n4 1 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n255 " + repeat("0 1 2 3 ", 63) + "0 1 2\n");
  up("face_count_lies", "off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n9 0 2 1\n", Expect::client, "7 declared counts");
  up("face_missing", "off", "OFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n", Expect::client, "6 importer crash");
  up("vertex_nan", "off", "OFF\n4 4 0\nnan 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("header_only", "off", "OFF\n");
  up("coff", "off", "COFF\n4 4 0\n0 0 0 1 1 1 1\n1 0 0 1 1 1 1\n0 1 0 1 1 1 1\n0 0 1 1 1 1 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", Expect::any);
  up("noff_short", "off", "NOFF\n4 4 0\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", Expect::any);
  up("four_off", "off", "4OFF\n4 4 0\n0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n3 0 2 1\n3 0 1 3\n3 0 3 2\n3 1 2 3\n", Expect::any);
  up("noff_dimension_huge", "off", "nOFF\n1000000\n4 4 0\n0 0 0\n");
  up("binary_off", "off", std::string("OFF BINARY\n") + le32(4) + le32(4) + le32(0) + std::string(64, '\0'));
  up("not_off", "off", "this is not an OFF file\n");
  up("faces_200001", "off", "OFF\n3 200001 0\n0 0 0\n1 0 0\n0 1 0\n" + repeat("3 0 1 2\n", 200001));

  // GLB.
  const std::vector<std::uint32_t> ti = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  up("valid", "glb", glb(tv, ti, 4, 12), Expect::ok);
  up("bad_magic", "glb", glb(tv, ti, 4, 12, "", true));
  up("length_too_big", "glb", glb(tv, ti, 4, 12, "", false, 100000), Expect::any);  // chunks read right
  up("length_too_small", "glb", glb(tv, ti, 4, 12, "", false, -40), Expect::any);
  up("index_out_of_range", "glb", glb(tv, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 99}, 4, 12), Expect::client, "7 bounds-checked indices");
  up("index_huge", "glb", glb(tv, {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 0xFFFFFFFFu}, 4, 12), Expect::client, "7 bounds-checked indices");
  up("position_count_huge", "glb", glb(tv, ti, 1000000000, 12), Expect::client, "7 declared counts");
  up("index_count_huge", "glb", glb(tv, ti, 4, 1000000000), Expect::client, "7 declared counts");
  up("index_count_not_multiple_of_3", "glb", glb(tv, ti, 4, 11), Expect::any);
  up("position_nan", "glb", glb({qnan, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1}, ti, 4, 12), Expect::client, "6/7 importer: non-finite coordinates accepted");
  up("external_uri_traversal", "glb", [&] {
    std::string s = glb(tv, ti, 4, 12);
    const std::string from = "\"buffers\":[{\"byteLength\":";
    s.replace(s.find(from), from.size(), "\"buffers\":[{\"uri\":\"../../../../etc/passwd\",\"byteLength\":");
    // The JSON chunk length changed: fix the header's lengths.
    const std::uint32_t json_len = static_cast<std::uint32_t>(s.find("BIN") - 4 - 20);
    std::memcpy(s.data() + 12, &json_len, 4);
    const std::uint32_t total = static_cast<std::uint32_t>(s.size());
    std::memcpy(s.data() + 8, &total, 4);
    return s;
  }());
  up("json_chunk_length_huge", "glb", [&] {
    std::string s = glb(tv, ti, 4, 12);
    const std::uint32_t big = 0xFFFFFFF0u;
    std::memcpy(s.data() + 12, &big, 4);
    return s;
  }());
  up("header_only", "glb", "glTF" + le32(2) + le32(12));
  up("json_garbage", "glb", "glTF" + le32(2) + le32(12 + 8 + 8) + le32(8) + "JSON" + "{{{{{{{{");
  up(
      "version_1", "glb", [&] {
        std::string s = glb(tv, ti, 4, 12);
        const std::uint32_t v = 1;
        std::memcpy(s.data() + 4, &v, 4);
        return s;
      }(),
      Expect::any);
  up("accessor_offset_out", "glb", [&] {
    std::string s = glb(tv, ti, 4, 12);
    const std::string from = "\"bufferView\":1,";
    s.replace(s.find(from), from.size(), "\"bufferView\":1,\"byteOffset\":4000,");
    const std::uint32_t json_len = static_cast<std::uint32_t>(s.find("BIN") - 4 - 20);
    std::memcpy(s.data() + 12, &json_len, 4);
    const std::uint32_t total = static_cast<std::uint32_t>(s.size());
    std::memcpy(s.data() + 8, &total, 4);
    return s;
  }());
  up("zeros", "glb", std::string(4096, '\0'));

  // The upload route itself.
  up("empty_body", "stl", "");
  Case fmt = make("upload/format_unknown", [](Ctx& c) { return http("POST", "/api/kelvin/uploads?format=exe", kTetraObj, c.session); });
  out.push_back(fmt);
  out.push_back(make("upload/format_missing", [](Ctx& c) { return http("POST", "/api/kelvin/uploads", kTetraObj, c.session); }));
  out.push_back(make("upload/format_traversal", [](Ctx& c) { return http("POST", "/api/kelvin/uploads?format=../../x", kTetraObj, c.session); }));
  out.push_back(make(
      "upload/format_case", [](Ctx& c) { return http("POST", "/api/kelvin/uploads?format=OBJ", kTetraObj, c.session); }, Expect::any));
  out.push_back(make("upload/format_mismatch_obj_as_stl", [](Ctx& c) { return http("POST", "/api/kelvin/uploads?format=stl", kTetraObj, c.session); }));
  out.push_back(make("upload/format_mismatch_stl_as_ply", [tstl](Ctx& c) { return http("POST", "/api/kelvin/uploads?format=ply", binary_stl(4, tstl), c.session); }));
  out.push_back(make("upload/no_session", [](Ctx&) { return http("POST", "/api/kelvin/uploads?format=obj", kTetraObj); }));
  out.push_back(make("upload/declared_over_limit", [](Ctx& c) {
    return "POST /api/kelvin/uploads?format=stl HTTP/1.1\r\nHost: x\r\nConnection: close\r\nX-Distlab-Session: " + c.session +
           "\r\nContent-Length: 200000000\r\n\r\n";  // over max_upload_bytes (128 MB)
  }));
}

// ---------------------------------------------------------------------------------------------
// Sessions: forged ids, no id, other sessions' ids on every session-scoped route.

inline void session_cases(std::vector<Case>& out) {
  const std::vector<std::pair<std::string, std::string>> routes = {
      {"GET", "/api/session"}, {"DELETE", "/api/session"}, {"GET", "/api/jobs"}, {"GET", "/api/jobs/{job}"}, {"POST", "/api/jobs/{job}/cancel"}, {"POST", "/api/kelvin/uploads?format=obj"}, {"POST", "/api/kelvin/objects"}, {"GET", "/api/kelvin/objects"}, {"GET", "/api/kelvin/objects/{object}"}, {"DELETE", "/api/kelvin/objects/{object}"}, {"GET", "/api/kelvin/objects/{object}/sigma"}, {"PUT", "/api/kelvin/objects/{object}/sigma"}, {"PUT", "/api/kelvin/objects/{object}/levels"}, {"POST", "/api/kelvin/objects/{object}/query"}, {"GET", "/api/kelvin/objects/{object}/isosurface?level=0.3"}, {"GET", "/api/kelvin/objects/{object}/surface"}, {"GET", "/api/kelvin/objects/{object}/export?level=0.3"}, {"POST", "/api/cbf/rollouts"}, {"GET", "/api/cbf/rollouts"}, {"GET", "/api/cbf/rollouts/{rollout}"}, {"GET", "/api/cbf/rollouts/{rollout}/frames"}, {"GET", "/api/cbf/rollouts/{rollout}/record"}, {"POST", "/api/robot/distances"}};
  const std::map<std::string, std::string> bodies = {
      {"/api/kelvin/uploads?format=obj", kTetraObj}, {"/api/kelvin/objects", json{{"asset", "cube"}, {"lx", 0.2}}.dump()}, {"/api/kelvin/objects/{object}/sigma", json{{"constant", 0.1}}.dump()}, {"/api/kelvin/objects/{object}/levels", json{{"levels", {0.1}}}.dump()}, {"/api/kelvin/objects/{object}/query", json{{"points", {{1, 0, 0}}}}.dump()}, {"/api/cbf/rollouts", json{{"scenario", "corridor"}, {"params", {{"duration", 0.03}}}}.dump()},
      // Only a URDF with meshes needs the session (its uploads).
      {"/api/robot/distances", json{{"robot", {{"urdf", "<robot name=\"r\"/>"}, {"meshes", {{"m.obj", "0123"}}}}}, {"q", json::array({0})}}.dump()}};
  // Forged session ids: refused (401 without one, 404 for one that does not exist).
  const std::vector<std::pair<std::string, std::string>> forged = {
      {"random_hex", "0123456789abcdef0123456789abcdef"}, {"short", "a"}, {"long_4k", std::string(4096, 'f')}, {"non_hex", "zzzzzzzzzzzzzzzzzzzzzzzzzzzzzzzz"}, {"sql", "' OR '1'='1"}, {"traversal", "../../etc/passwd"}, {"unicode", "\xc3\xa9\xc3\xa9"}, {"spaces", "   "}};
  for (const auto& r : routes) {
    const std::string m = r.first, route = r.second;
    const std::string body = bodies.count(route) ? bodies.at(route) : "";
    const std::string slug = m + "_" + route.substr(5, route.find('?') == std::string::npos ? std::string::npos : route.find('?') - 5);
    for (const auto& f : forged) {
      const std::string id = f.second;
      out.push_back(make("session/forged_" + f.first + "/" + slug, [m, route, body, id](Ctx& c) {
        std::string t = route;
        for (const auto& [k, v] : {std::pair<std::string, std::string>{"{object}", c.object}, {"{job}", c.job}, {"{rollout}", c.rollout}})
          for (std::size_t p; (p = t.find(k)) != std::string::npos;) t.replace(p, k.size(), v);
        return http(m, t, body, id);
      }));
    }
    out.push_back(make(
        "session/none/" + slug, [m, route, body](Ctx& c) {
          std::string t = route;
          for (const auto& [k, v] : {std::pair<std::string, std::string>{"{object}", c.object}, {"{job}", c.job}, {"{rollout}", c.rollout}})
            for (std::size_t p; (p = t.find(k)) != std::string::npos;) t.replace(p, k.size(), v);
          return http(m, t, body);
        },
        Expect::status));
    out.back().status = 401;
    // Another session's resource ids answer 404 (the suite's session asks for the other's ids).
    if (route.find('{') != std::string::npos) {
      out.push_back(make(
          "session/other_ids/" + slug, [m, route, body](Ctx& c) {
            std::string t = route;
            for (const auto& [k, v] : {std::pair<std::string, std::string>{"{object}", c.other_object}, {"{job}", c.other_job}, {"{rollout}", c.other_rollout}})
              for (std::size_t p; (p = t.find(k)) != std::string::npos;) t.replace(p, k.size(), v);
            return http(m, t, body, c.session);
          },
          Expect::status));
      out.back().status = 404;
    }
  }
  // The session id through the cookie and the query string, forged.
  out.push_back(make(
      "session/cookie_forged", [](Ctx&) {
        return http("GET", "/api/session", "", "", "Cookie: distlab_session=0123456789abcdef0123456789abcdef\r\n");
      },
      Expect::status));
  out.back().status = 404;
  out.push_back(make(
      "session/query_forged", [](Ctx&) { return http("GET", "/api/session?session=00", ""); }, Expect::status));
  out.back().status = 404;
  out.push_back(make(
      "session/header_and_cookie_differ", [](Ctx& c) {
        return http("GET", "/api/kelvin/objects/" + c.other_object, "", c.session, "Cookie: distlab_session=" + c.other_session + "\r\n");
      },
      Expect::status));
  out.back().status = 404;
  out.push_back(make(
      "session/post_session_with_body", [](Ctx&) { return http("POST", "/api/session", std::string(100000, 'x')); }, Expect::any));
}

// ---------------------------------------------------------------------------------------------
// Static paths.

inline void static_cases(std::vector<Case>& out) {
  auto no_secret = [](const Reply& r, Ctx&) -> std::string {
    return r.body.find("secret") != std::string::npos || r.body.find("root:") != std::string::npos ? " served a file outside the web root;" : "";
  };
  auto st = [&](std::string name, std::string target, Expect e = Expect::client) {
    Case c = make(
        "static/" + name, [target](Ctx& ctx) {
          (void)ctx;
          return "GET " + target + " HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
        },
        e);
    c.check = no_secret;
    out.push_back(c);
  };
  // The fixture writes <web>-secret.txt next to the web directory: every way to it must fail.
  for (const auto& [name, t] : std::vector<std::pair<std::string, std::string>>{
           {"dotdot_passwd", "/../../../../etc/passwd"}, {"dotdot_encoded", "/%2e%2e/%2e%2e/%2e%2e/etc/passwd"}, {"dotdot_encoded_upper", "/%2E%2E/%2E%2E/etc/passwd"}, {"slash_encoded", "/..%2f..%2f..%2fetc%2fpasswd"}, {"double_encoded", "/%252e%252e/%252e%252e/etc/passwd"}, {"backslash", "/..\\..\\etc\\passwd"}, {"backslash_encoded", "/..%5c..%5cetc%5cpasswd"}, {"js_up", "/js/../../etc/passwd"}, {"absolute_double_slash", "//etc/passwd"}, {"nul", "/index.html%00.js"}, {"nul_raw_percent", "/%00"}, {"overlong_dot", "/%c0%ae%c0%ae/etc/passwd"}, {"dot_segment", "/./index.html"}, {"api_up", "/api/../index.html"}, {"proc_self", "/../../../proc/self/environ"}, {"bad_percent", "/%zz"}, {"trailing_percent", "/index.html%"}, {"long_8k", "/" + std::string(8000, 'a')}, {"many_segments", repeat("/a", 3000)}, {"dir_js", "/js/"}, {"dir_js_no_slash", "/js"}}) {
    const bool ok_expected = name == "dir_js" || name == "dir_js_no_slash";
    st(name, t, ok_expected ? Expect::any : Expect::client);
  }
  // The secret's own name, reached by every traversal form.
  for (const std::string pre : {"/..", "/%2e%2e", "/%2E%2e", "/js/../.."}) {
    Case c = make("static/secret_" + pre.substr(1), [pre](Ctx& ctx) {
      return "GET " + pre + "/" + fs::path(ctx.web_dir).filename().string() + "-secret.txt HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
    });
    c.check = no_secret;
    out.push_back(c);
  }
  st("index_ok", "/", Expect::ok);
  st("app_js_ok", "/js/app.js", Expect::ok);
  Case post = make(
      "static/post", [](Ctx&) { return http("POST", "/index.html", "x"); }, Expect::status);
  post.status = 405;
  out.push_back(post);
}

// ---------------------------------------------------------------------------------------------
// WebSocket frames.

inline void ws_cases(std::vector<Case>& out) {
  // Sends one message and reads until the reply (an error with a 4xx status, or `want_type`).
  auto ws = [&](std::string name, std::function<void(WsClient&, Ctx&)> send, std::string want_type, std::string why = "") {
    Case c;
    c.name = "ws/" + name;
    c.why = why;
    c.custom = [send, want_type](Ctx& ctx) {
      Outcome o;
      try {
        WsClient w(ctx.port, ctx.session);
        WsClient::Message m;
        send(w, ctx);
        // A ping after it: a pong first means the message was accepted without a word.
        if (want_type != "pong" && want_type != "close") w.send_raw("{\"type\":\"ping\"}");
        const bool got = w.until(
            [&](const WsClient::Message& x) {
              if (x.binary) return false;
              const std::string t = x.j.is_object() ? x.j.value("type", "") : "";
              return t == "error" || t == "sigma" || t == "pong" || t == want_type || x.j.is_discarded();
            },
            m, 20);
        if (!got) {
          if (want_type != "close") o.problem = " no reply (" + w.error().message() + ");";
          return o;
        }
        if (has_nonfinite_token(m.data)) o.problem += " NaN/Infinity in a reply;";
        if (m.j.is_discarded()) o.problem += " a reply is not JSON;";
        const std::string t = m.j.value("type", "");
        if ((want_type == "error" || want_type == "close") && t == "error") {
          const int st = m.j.value("status", 0);
          if (st < 400 || st >= 500) o.problem += " error status " + std::to_string(st) + ";";
        } else if (t != want_type) {
          o.problem += " got \"" + t + "\" (" + m.data.substr(0, 120) + "), not \"" + want_type + "\";";
        }
      } catch (const std::exception& e) {
        if (want_type != "close") o.problem = std::string(" WebSocket failed: ") + e.what() + ";";
      }
      return o;
    };
    out.push_back(c);
  };
  auto text = [](std::string s) { return [s](WsClient& w, Ctx&) { w.send_raw(s); }; };
  ws("bad_json", text("{"), "error");
  ws("not_object", text("[1,2]"), "error");
  ws("no_type", text("{}"), "error");
  ws("type_number", text("{\"type\":1}"), "error");
  ws("type_unknown", text("{\"type\":\"launch\"}"), "error");
  ws("nan", text("{\"type\":\"watch\",\"object\":\"x\",\"levels\":[NaN]}"), "error");
  ws("number_1e999", text("{\"type\":\"ping\",\"x\":1e999}"), "error");
  ws("deep", text(std::string(5000, '[')), "error");
  ws("duplicate_key", text("{\"type\":\"ping\",\"type\":\"state\"}"), "error");
  // Invalid UTF-8 in a text frame fails the connection (RFC 6455 8.1): a close, not an answer.
  ws("invalid_utf8", text("{\"type\":\"\xff\"}"), "close");
  ws("request_id_long", text("{\"type\":\"ping\",\"request\":\"" + std::string(100, 'r') + "\"}"), "error");
  ws("request_id_object", text("{\"type\":\"ping\",\"request\":{}}"), "error");
  ws("ping", text("{\"type\":\"ping\"}"), "pong");
  ws("watch_unknown_object", text("{\"type\":\"watch\",\"object\":\"ffff\",\"levels\":[0.1]}"), "error");
  ws(
      "watch_other_session_object", [](WsClient& w, Ctx& c) { w.send({{"type", "watch"}, {"object", c.other_object}, {"levels", {0.1}}}); }, "error");
  ws(
      "watch_levels_17", [](WsClient& w, Ctx& c) { w.send({{"type", "watch"}, {"object", c.object}, {"levels", std::vector<double>(17, 0.1)}}); }, "error");
  ws(
      "watch_levels_string", [](WsClient& w, Ctx& c) { w.send({{"type", "watch"}, {"object", c.object}, {"levels", "0.1"}}); }, "error");
  ws(
      "watch_no_levels", [](WsClient& w, Ctx& c) { w.send({{"type", "watch"}, {"object", c.object}}); }, "error");
  ws(
      "watch_unknown_key", [](WsClient& w, Ctx& c) { w.send({{"type", "watch"}, {"object", c.object}, {"levels", json::array()}, {"bogus", 1}}); }, "error", "13 unknown keys");
  ws(
      "sigma_bad", [](WsClient& w, Ctx& c) { w.send({{"type", "sigma"}, {"object", c.object}, {"sigma", {{"constant", "x"}}}}); }, "error");
  ws(
      "sigma_1e300", [](WsClient& w, Ctx& c) { w.send({{"type", "sigma"}, {"object", c.object}, {"sigma", {{"constant", 1e300}}}}); }, "error", "5 σ range");
  ws(
      "sigma_other_session_object", [](WsClient& w, Ctx& c) { w.send({{"type", "sigma"}, {"object", c.other_object}, {"sigma", {{"constant", 0.1}}}}); }, "error");
  ws(
      "sigma_missing", [](WsClient& w, Ctx& c) { w.send({{"type", "sigma"}, {"object", c.object}}); }, "error");
  ws(
      "cancel_other_session_job", [](WsClient& w, Ctx& c) { w.send({{"type", "cancel"}, {"job", c.other_job}}); }, "error");
  ws("cancel_forged_job", text("{\"type\":\"cancel\",\"job\":\"0000\"}"), "error");
  ws(
      "cbf_replay_other_session", [](WsClient& w, Ctx& c) { w.send({{"type", "cbf_replay"}, {"rollout", c.other_rollout}}); }, "error");
  ws(
      "cbf_replay_from_negative", [](WsClient& w, Ctx& c) { w.send({{"type", "cbf_replay"}, {"rollout", c.rollout}, {"from", -1}}); }, "error");
  ws(
      "cbf_replay_from_huge", [](WsClient& w, Ctx& c) { w.send({{"type", "cbf_replay"}, {"rollout", c.rollout}, {"from", 1e300}}); }, "error");
  ws("cbf_unknown", text("{\"type\":\"cbf_fly\"}"), "error");
  ws(
      "binary_junk", [](WsClient& w, Ctx&) {
        std::string junk(300, '\0');
        std::mt19937 g(3);
        for (auto& ch : junk) ch = static_cast<char>(g());
        w.send_binary(junk);
      },
      "error");
  // Oversize: the server closes (1009); then it must still serve others.
  ws(
      "oversize_2mb", [](WsClient& w, Ctx&) { w.send_raw("{\"type\":\"ping\",\"x\":\"" + std::string(2 << 20, 'x') + "\"}"); }, "close");
  // Rate: a burst far past the bucket answers rate_limited errors, then the socket is closed.
  Case rate;
  rate.name = "ws/rate_1000_messages";
  rate.custom = [](Ctx& ctx) {
    Outcome o;
    try {
      WsClient w(ctx.port, ctx.session);
      for (int i = 0; i < 1000; ++i) w.send_raw("{\"type\":\"ping\"}");
      WsClient::Message m;
      int limited = 0;
      // Until the first refusal: a loaded server may fall silent for seconds among its replies
      // (failed once in a full ctest run with a 2 s wait).
      while (limited == 0 && w.read(m, 15))
        if (!m.binary && m.j.is_object() && m.j.contains("error") && m.j["error"].value("code", "") == "rate_limited") ++limited;
      if (limited == 0) o.problem = " no rate_limited error for 1000 messages at once;";
    } catch (const std::exception&) {
      // The server may close before every message is written: that is the limit working.
    }
    return o;
  };
  out.push_back(rate);
  // Forged sessions at the handshake.
  for (const auto& h : std::vector<std::pair<std::string, std::string>>{
           {"handshake_forged_session", "/ws?session=0123456789abcdef0123456789abcdef"},
           {"handshake_no_session", "/ws"},
           {"handshake_long_session", "/ws?session=" + std::string(5000, 'a')},
           {"handshake_wrong_path", "/wss?session=x"}}) {
    const std::string target = h.second;
    out.push_back(make("ws/" + h.first, [target](Ctx&) {
      return "GET " + target +
             " HTTP/1.1\r\nHost: x\r\nConnection: Upgrade\r\nUpgrade: websocket\r\nSec-WebSocket-Version: 13\r\n"
             "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n";
    }));
  }
  // Many sockets of one session at once (bounded: 32), then a ping still works.
  Case many;
  many.name = "ws/sockets_32";
  many.custom = [](Ctx& ctx) {
    Outcome o;
    try {
      std::vector<std::unique_ptr<WsClient>> socks;
      for (int i = 0; i < 32; ++i) socks.push_back(std::make_unique<WsClient>(ctx.port, ctx.session));
      socks.back()->send({{"type", "ping"}});
      WsClient::Message m;
      if (!socks.back()->until([](const WsClient::Message& x) { return !x.binary && x.j.value("type", "") == "pong"; }, m, 20))
        o.problem = " no pong with 32 sockets open;";
    } catch (const std::exception& e) {
      o.problem = std::string(" ") + e.what() + ";";
    }
    return o;
  };
  out.push_back(many);
}

// ---------------------------------------------------------------------------------------------
// Scene items and recordings (routes_scene.cpp): an item is one msgpack frame, so the msgpack
// itself is hostile here too (truncated, lying counts, deep, the wrong types), then every field
// of the item, the pose route, the limits, the recordings' requests, parts and ends, and another
// session's names. Every refusal must name its field (the request as a whole: "", the msgpack
// itself: "body"). Run with small scene limits (test_hostile_requests.cpp, Hostile.Scene).

namespace scene {

// The limits the Scene runner starts the server with (the one-over cases stay a few kB).
inline constexpr std::size_t kItems = 4, kVertices = 1000, kBytes = 50000, kRecordFrames = 4, kRecordBytes = 100000;

inline std::string msgpack_request(const std::string& method, const std::string& target, const std::string& body,
                                   const std::string& session, const std::string& extra_headers = "") {
  std::string r = method + " " + target + " HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n";
  if (!session.empty()) r += "X-Distlab-Session: " + session + "\r\n";
  return r + "Content-Type: application/msgpack\r\nContent-Length: " + std::to_string(body.size()) + "\r\n" +
         extra_headers + "\r\n" + body;
}

inline std::string packed(const json& j) {
  const auto v = json::to_msgpack(j);
  return {v.begin(), v.end()};
}

// A msgpack bin of 4-byte little-endian values (the frames' arrays).
template <class T>
json bin(const std::vector<T>& values) {
  static_assert(sizeof(T) == 4);
  std::vector<std::uint8_t> b(values.size() * 4);
  if (!b.empty()) std::memcpy(b.data(), values.data(), b.size());
  return json::binary(std::move(b));
}

inline json bytes(std::size_t n) { return json::binary(std::vector<std::uint8_t>(n, 0)); }

// n points on a line, 3 floats each.
inline std::vector<float> line_points(std::size_t n) {
  std::vector<float> p(3 * n, 0.0f);
  for (std::size_t i = 0; i < n; ++i) p[3 * i] = static_cast<float>(i) * 0.001f;
  return p;
}

// A triangle: three points, one face.
inline json triangle() {
  return {{"kind", "mesh"}, {"positions", bin<float>({0, 0, 0, 1, 0, 0, 0, 1, 0})}, {"indices", bin<std::uint32_t>({0, 1, 2})}};
}
inline json points() { return {{"kind", "points"}, {"positions", bin<float>({0, 0, 0, 1, 0, 0, 0, 1, 0})}}; }

// The error names `field` and, when `code` is given, has that code.
inline std::function<std::string(const Reply&, Ctx&)> names(std::string field, std::string code = "") {
  return [field, code](const Reply& r, Ctx& ctx) -> std::string {
    std::string problem = field_is(field)(r, ctx);
    const json j = json::parse(r.body, nullptr, false);
    if (problem.empty() && !code.empty() && j["error"].value("code", "") != code)
      problem = " error code \"" + j["error"].value("code", "") + "\", not \"" + code + "\";";
    return problem;
  };
}

// A 2xx whose pose has a unit quaternion (a rotation, not its overflow).
inline std::string unit_pose(const Reply& r, Ctx&) {
  const json j = json::parse(r.body, nullptr, false);
  if (!j.is_object() || !j.contains("pose")) return " no pose in the answer;";
  double n2 = 0;
  for (const auto& q : j["pose"]["quaternion"]) n2 += q.get<double>() * q.get<double>();
  return std::abs(n2 - 1) < 1e-12 ? "" : " the pose's quaternion has norm² " + json(n2).dump() + ", not 1 (" + r.body.substr(0, 160) + ");";
}

// Sessions and what the other one holds: an item and a recording (never this session's).
inline void setup(Ctx& ctx, ServerProcess& server) {
  ctx.web_dir = server.web_dir();
  ctx.session = make_session(ctx);
  ctx.other_session = make_session(ctx);
  exchange(ctx.port, msgpack_request("PUT", "/api/scene/items/theirs", packed(points()), ctx.other_session), 30);
  const json r = json::parse(call(ctx, "POST", "/api/scene/recordings", json{{"view", "gap"}, {"format", "png"}, {"frames", 2}}.dump(), ctx.other_session).body,
                             nullptr, false);
  ctx.other_recording = r.is_object() && r.contains("id") ? r["id"].get<std::string>() : "";
  // The item the pose cases move.
  exchange(ctx.port, msgpack_request("PUT", "/api/scene/items/posed", packed(points()), ctx.session), 30);
}

}  // namespace scene

inline void scene_cases(std::vector<Case>& out) {
  using namespace scene;
  const float qnan = std::numeric_limits<float>::quiet_NaN(), pinf = std::numeric_limits<float>::infinity();
  const double dnan = std::numeric_limits<double>::quiet_NaN(), dinf = std::numeric_limits<double>::infinity();

  // PUT /api/scene/items/{name} with raw bytes; `field`: the field the refusal must name.
  auto item_bytes = [&](std::string name, std::string body, Expect e, std::string field, std::string code = "", std::string target = "/api/scene/items/x") {
    out.push_back(make(
        "scene/item_" + name, [body, target](Ctx& c) { return msgpack_request("PUT", target, body, c.session); }, e));
    if (e == Expect::client || e == Expect::status) out.back().check = names(field, code);
  };
  auto item = [&](std::string name, json frame, std::string field) { item_bytes(name, packed(frame), Expect::client, field); };
  auto with = [](json base, const std::string& key, json value) {
    base[key] = std::move(value);
    return base;
  };

  // Valid items of each kind (the answers must be summaries, no NaN).
  item_bytes("points_ok", packed(points()), Expect::ok, "");
  item_bytes("mesh_ok", packed(triangle()), Expect::ok, "");
  item_bytes("lines_ok", packed({{"kind", "lines"}, {"positions", bin<float>({0, 0, 0, 1, 0, 0})}, {"indices", bin<std::uint32_t>({0, 1})}}), Expect::ok, "");
  item_bytes("frame_ok", packed({{"kind", "frame"}, {"size", 0.2}, {"view", "cbf"}, {"pose", {{"position", {0, 0, 1}}}}}), Expect::ok, "");
  item_bytes("full_ok", packed(with(with(with(triangle(), "colors", bin<float>({1, 0, 0, 0, 1, 0, 0, 0, 1})), "scalars", bin<float>({-1e30f, 0, 1e30f})), "view", "kelvin")),
             Expect::ok, "");

  // The msgpack itself: truncated, trailing bytes, lying counts and lengths, not msgpack.
  const std::string valid = packed(triangle());
  item_bytes("msgpack_empty", "", Expect::client, "body");
  item_bytes("msgpack_truncated_half", valid.substr(0, valid.size() / 2), Expect::client, "body");
  item_bytes("msgpack_truncated_last_byte", valid.substr(0, valid.size() - 1), Expect::client, "body");
  item_bytes("msgpack_one_byte_map", std::string("\x82", 1), Expect::client, "body");
  item_bytes("msgpack_trailing_byte", valid + std::string(1, '\0'), Expect::client, "body");
  item_bytes("msgpack_two_frames", valid + valid, Expect::client, "body");
  item_bytes("msgpack_json_text", triangle().dump(), Expect::client, "body");
  item_bytes("msgpack_reserved_c1", std::string("\x81\xa4kind\xc1", 7), Expect::client, "body");
  item_bytes("msgpack_map32_count_huge", std::string("\xdf\xff\xff\xff\xff\xa4kind", 10), Expect::client, "body");
  item_bytes("msgpack_array32_count_huge", std::string("\x81\xa9positions\xdd\xff\xff\xff\xff", 16), Expect::client, "body");
  item_bytes("msgpack_bin32_length_huge", std::string("\x82\xa4kind\xa6points\xa9positions\xc6\xff\xff\xff\xff\0\0\0\0", 32), Expect::client, "body");
  item_bytes("msgpack_str32_length_huge", std::string("\x81\xdb\xff\xff\xff\xff", 6), Expect::client, "body");
  item_bytes("msgpack_ext32_length_huge", std::string("\x82\xa4kind\xa6points\xa9positions\xc9\xff\xff\xff\xff\x01", 29), Expect::client, "body");
  item_bytes("msgpack_key_not_string", std::string("\x81\x01\x02", 3), Expect::client, "body");
  item_bytes("msgpack_key_binary", std::string("\x81\xc4\x04kind\xa6points", 14), Expect::client, "body");
  item_bytes("msgpack_nested_100000", std::string(100000, '\x91'), Expect::client, "");  // the depth limit: the request as a whole
  item_bytes("msgpack_nested_maps", repeat(std::string("\x81\xa1k", 3), 1000) + std::string("\xc0", 1), Expect::client, "");
  item_bytes("msgpack_root_nil", std::string("\xc0", 1), Expect::client, "");
  item_bytes("msgpack_root_array", packed(json::array({1, 2, 3})), Expect::client, "");
  item_bytes("msgpack_root_binary", std::string("\xc4\x01x", 3), Expect::client, "");
  item_bytes("msgpack_root_nan", std::string("\xcb\x7f\xf8\0\0\0\0\0\0", 9), Expect::client, "");
  item_bytes("msgpack_duplicate_key", std::string("\x82\xa4kind\xa4mesh\xa4kind\xa4mesh", 21), Expect::client, "kind");
  std::string junk(4000, '\0');
  std::mt19937 g(11);
  for (auto& ch : junk) ch = static_cast<char>(g());
  item_bytes("msgpack_random_bytes", junk, Expect::client, "body");
  item_bytes("msgpack_random_after_map", std::string("\x83", 1) + junk, Expect::client, "body");

  // Keys and kinds.
  item("kind_missing", {{"positions", bin<float>({0, 0, 0})}}, "kind");
  item("kind_unknown", with(points(), "kind", "cube"), "kind");
  item("kind_empty", with(points(), "kind", ""), "kind");
  item("kind_number", with(points(), "kind", 1), "kind");
  item("kind_nil", with(points(), "kind", nullptr), "kind");
  item("kind_array", with(points(), "kind", {"points"}), "kind");
  item("view_unknown", with(points(), "view", "plots"), "view");
  item("view_number", with(points(), "view", 3), "view");
  item("view_nil", with(points(), "view", nullptr), "view");
  item("unknown_key", with(points(), "zz_unknown", 1), "zz_unknown");
  item("server_key_type", with(points(), "type", "scene_item"), "type");
  item("server_key_n_vertices", with(points(), "n_vertices", 1000000), "n_vertices");
  item("server_key_name", with(points(), "name", "other"), "name");
  // Arrays: missing, not bin (an ext is no bin either), lengths that are no rows.
  item("positions_missing", {{"kind", "points"}}, "positions");
  item("positions_array", with(points(), "positions", {0, 0, 0, 1, 0, 0}), "positions");
  item("positions_string", with(points(), "positions", "000"), "positions");
  item("positions_nil", with(points(), "positions", nullptr), "positions");
  item("positions_ext", with(points(), "positions", json::binary(std::vector<std::uint8_t>(36, 0), 5)), "positions");
  item("positions_empty", with(points(), "positions", bytes(0)), "positions");
  item("positions_13_bytes", with(points(), "positions", bytes(13)), "positions");
  item("positions_one_float", with(points(), "positions", bytes(4)), "positions");
  item("indices_ext", with(triangle(), "indices", json::binary(std::vector<std::uint8_t>(12, 0), 1)), "indices");
  item("colors_ext", with(points(), "colors", json::binary(std::vector<std::uint8_t>(36, 0), 2)), "colors");
  item("scalars_ext", with(points(), "scalars", json::binary(std::vector<std::uint8_t>(12, 0), 3)), "scalars");
  // NaN, infinities and huge coordinates.
  item("positions_nan", with(points(), "positions", bin<float>({0, 0, 0, 1, 0, qnan, 0, 1, 0})), "positions[1][2]");
  item("positions_inf", with(points(), "positions", bin<float>({pinf, 0, 0, 1, 0, 0, 0, 1, 0})), "positions[0][0]");
  item("positions_minus_inf", with(points(), "positions", bin<float>({0, 0, 0, 1, 0, 0, 0, -pinf, 0})), "positions[2][1]");
  item("positions_1e7", with(points(), "positions", bin<float>({1e7f, 0, 0})), "positions[0][0]");
  item("positions_float_max", with(points(), "positions", bin<float>({0, 0, std::numeric_limits<float>::max()})), "positions[0][2]");
  item_bytes("positions_denormal", packed(with(points(), "positions", bin<float>({1e-45f, 0, 0}))), Expect::ok, "");
  item("colors_nan", with(points(), "colors", bin<float>({qnan, 0, 0, 0, 0, 0, 0, 0, 0})), "colors[0][0]");
  item("colors_above_one", with(points(), "colors", bin<float>({0, 0, 0, 0, 2, 0, 0, 0, 0})), "colors[1][1]");
  item("colors_negative", with(points(), "colors", bin<float>({0, 0, 0, 0, 0, 0, 0, 0, -0.5f})), "colors[2][2]");
  item("colors_short", with(points(), "colors", bin<float>({0, 0, 0})), "colors");
  item("colors_array", with(points(), "colors", {0, 0, 0, 0, 0, 0, 0, 0, 0}), "colors");
  item("scalars_nan", with(points(), "scalars", bin<float>({0, qnan, 0})), "scalars[1][0]");
  item("scalars_inf", with(points(), "scalars", bin<float>({-pinf, 0, 0})), "scalars[0][0]");
  item("scalars_short", with(points(), "scalars", bin<float>({0, 0})), "scalars");
  // Indices: missing, where none belong, out of range, not whole rows.
  item("indices_missing", {{"kind", "mesh"}, {"positions", bin<float>({0, 0, 0, 1, 0, 0, 0, 1, 0})}}, "indices");
  item("indices_on_points", with(points(), "indices", bin<std::uint32_t>({0, 1, 2})), "indices");
  item("indices_empty", with(triangle(), "indices", bytes(0)), "indices");
  item("indices_out_of_range", with(triangle(), "indices", bin<std::uint32_t>({0, 1, 3})), "indices[0][2]");
  item("indices_uint32_max", with(triangle(), "indices", bin<std::uint32_t>({0, 0xFFFFFFFFu, 2})), "indices[0][1]");
  item("indices_11_bytes", with(triangle(), "indices", bytes(11)), "indices");
  item("indices_lines_odd", {{"kind", "lines"}, {"positions", bin<float>({0, 0, 0, 1, 0, 0})}, {"indices", bin<std::uint32_t>({0, 1, 1})}}, "indices");
  item("indices_array", with(triangle(), "indices", {0, 1, 2}), "indices");
  item("frame_with_positions", {{"kind", "frame"}, {"positions", bin<float>({0, 0, 0})}}, "positions");
  item("frame_with_indices", {{"kind", "frame"}, {"indices", bin<std::uint32_t>({0, 0, 0})}}, "indices");
  // Colour, size and pose: msgpack carries NaN and infinities that JSON text cannot.
  item("color_nan", with(points(), "color", {dnan, 0, 0}), "color[0]");
  item("color_inf", with(points(), "color", {0, dinf, 0}), "color[1]");
  item("color_above_one", with(points(), "color", {0, 0, 2}), "color[2]");
  item("color_two", with(points(), "color", {0, 0}), "color");
  item("color_string", with(points(), "color", "red"), "color");
  item("size_nan", with(points(), "size", dnan), "size");
  item("size_inf", with(points(), "size", dinf), "size");
  item("size_zero", with(points(), "size", 0), "size");
  item("size_negative", with(points(), "size", -1), "size");
  item("size_1e300", with(points(), "size", 1e300), "size");
  item("size_string", with(points(), "size", "2"), "size");
  item("size_binary", with(points(), "size", bytes(4)), "size");
  item("pose_position_nan", with(points(), "pose", {{"position", {dnan, 0, 0}}}), "pose.position[0]");
  item("pose_position_inf", with(points(), "pose", {{"position", {0, 0, -dinf}}}), "pose.position[2]");
  item("pose_position_1e300", with(points(), "pose", {{"position", {0, 1e300, 0}}}), "pose.position[1]");
  item("pose_quaternion_zero", with(points(), "pose", {{"quaternion", {0, 0, 0, 0}}}), "pose.quaternion");
  item("pose_quaternion_nan", with(points(), "pose", {{"quaternion", {1, dnan, 0, 0}}}), "pose.quaternion[1]");
  item("pose_quaternion_three", with(points(), "pose", {{"quaternion", {1, 0, 0}}}), "pose.quaternion");
  item("pose_unknown_key", with(points(), "pose", {{"scale", 2}}), "pose.scale");
  item("pose_array", with(points(), "pose", {0, 0, 0}), "pose");
  // A quaternion whose norm overflows a double is still a direction: normalised, not zeroed.
  item_bytes("pose_quaternion_1e308", packed(with(points(), "pose", {{"quaternion", {1e308, 1e308, 1e308, 1e308}}})), Expect::ok, "");
  out.back().check = unit_pose;

  // Names: the path's; a name that is no name is refused naming it.
  for (const auto& [label, name] : std::vector<std::pair<std::string, std::string>>{
           {"space", "a%20b"}, {"dot", "."}, {"dots", ".."}, {"long_65", std::string(65, 'n')}, {"nul", "a%00"}, {"unicode", "%C3%A9"}, {"slash", "a%2Fb"}})
    item_bytes("name_" + label, valid, Expect::client, "name", "", "/api/scene/items/" + name);

  // The limits, each in a session of its own: vertices, items, bytes, the body.
  auto fresh = [&](std::string name, std::function<std::string(Ctx&, const std::string&)> request, Expect e, std::string field, std::string code) {
    out.push_back(make(
        "scene/" + name, [request](Ctx& c) { return request(c, make_session(c)); }, e));
    out.back().check = names(std::move(field), std::move(code));
  };
  auto put_in = [](Ctx& c, const std::string& s, const std::string& name, const json& frame) {
    exchange(c.port, msgpack_request("PUT", "/api/scene/items/" + name, packed(frame), s), 30);
  };
  fresh(
      "limit_vertices", [](Ctx&, const std::string& s) {
        return msgpack_request("PUT", "/api/scene/items/many", packed({{"kind", "points"}, {"positions", bin(line_points(kVertices + 1))}}), s);
      },
      Expect::status, "positions", "too_many_vertices");
  out.back().status = 413;
  fresh(
      "limit_items", [put_in](Ctx& c, const std::string& s) {
        for (std::size_t i = 0; i < kItems; ++i) put_in(c, s, std::string("p").append(std::to_string(i)), points());
        return msgpack_request("PUT", "/api/scene/items/one_more", packed(points()), s);
      },
      Expect::status, "name", "too_many_items");
  out.back().status = 413;
  fresh(
      "limit_items_replace_ok", [put_in](Ctx& c, const std::string& s) {
        for (std::size_t i = 0; i < kItems; ++i) put_in(c, s, std::string("p").append(std::to_string(i)), points());
        return msgpack_request("PUT", "/api/scene/items/p0", packed(triangle()), s);  // replacing is no new item
      },
      Expect::ok, "", "");
  out.back().check = {};
  fresh(
      "limit_bytes", [put_in](Ctx& c, const std::string& s) {
        // Two items of 1000 coloured points with values: 28 kB each, 56 kB together, above 50 kB.
        const std::vector<float> p = line_points(kVertices), colors(3 * kVertices, 0.5f), values(kVertices, 1.0f);
        const json big = {{"kind", "points"}, {"positions", bin(p)}, {"colors", bin(colors)}, {"scalars", bin(values)}};
        put_in(c, s, "first", big);
        return msgpack_request("PUT", "/api/scene/items/second", packed(big), s);
      },
      Expect::status, "body", "too_many_bytes");
  out.back().status = 413;
  // Bodies above the route's limit (max_scene_bytes + 64 kB), declared: refused before they are read
  // (nothing sent after the head, so that the server's close cannot reset the answer away).
  out.push_back(make(
      "scene/item_body_declared_over_limit", [](Ctx& c) {
        return "PUT /api/scene/items/x HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nX-Distlab-Session: " + c.session +
               "\r\nContent-Type: application/msgpack\r\nContent-Length: " + std::to_string(kBytes + (64 << 10) + 1) + "\r\n\r\n";
      },
      Expect::status));
  out.back().status = 413;
  out.push_back(make(
      "scene/item_body_declared_4gb", [](Ctx& c) {
        return "PUT /api/scene/items/x HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nX-Distlab-Session: " + c.session +
               "\r\nContent-Type: application/msgpack\r\nContent-Length: 4294967296\r\n\r\n";
      },
      Expect::status));
  out.back().status = 413;

  // Sessions: none, forged, another session's item and recording.
  out.push_back(make(
      "scene/item_no_session", [valid](Ctx&) { return msgpack_request("PUT", "/api/scene/items/x", valid, ""); }, Expect::status));
  out.back().status = 401;
  out.push_back(make(
      "scene/item_forged_session", [valid](Ctx&) { return msgpack_request("PUT", "/api/scene/items/x", valid, "0123456789abcdef0123456789abcdef"); }, Expect::status));
  out.back().status = 404;
  out.push_back(make(
      "scene/items_list_no_session", [](Ctx&) { return http("GET", "/api/scene/items"); }, Expect::status));
  out.back().status = 401;
  out.push_back(make(
      "scene/clear_forged_session", [](Ctx&) { return http("DELETE", "/api/scene/items", "", "ffffffffffffffffffffffffffffffff"); }, Expect::status));
  out.back().status = 404;
  auto other = [&](std::string name, std::string method, std::string target, std::string body, std::string field, int status = 404) {
    out.push_back(make(
        "scene/other_session_" + name, [method, target, body](Ctx& c) {
          std::string t = target;
          for (std::size_t p; (p = t.find("{other_recording}")) != std::string::npos;) t.replace(p, 17, c.other_recording);
          return http(method, t, body, c.session);
        },
        Expect::status));
    out.back().status = status;
    out.back().check = names(field);
  };
  other("item_pose", "PUT", "/api/scene/items/theirs/pose", json{{"pose", {{"position", {0, 0, 0}}}}}.dump(), "name");
  other("item_delete", "DELETE", "/api/scene/items/theirs", "", "name");
  other("recording_get", "GET", "/api/scene/recordings/{other_recording}", "", "id");
  other("recording_part", "PUT", "/api/scene/recordings/{other_recording}/parts/0", "PNG", "id");
  other("recording_finish", "POST", "/api/scene/recordings/{other_recording}/finish", json{{"error", "no"}}.dump(), "id");
  other("recording_part_get", "GET", "/api/scene/recordings/{other_recording}/parts/0", "", "id");
  other("recording_delete", "DELETE", "/api/scene/recordings/{other_recording}", "", "id");

  // The pose route (JSON text), on this session's item "posed".
  const std::string pose_target = "/api/scene/items/posed/pose";
  auto pose = [&](std::string name, std::string body, Expect e, std::string field, std::string target = "/api/scene/items/posed/pose") {
    out.push_back(api("scene/pose_" + name, "PUT", target, body, e));
    if (e == Expect::client) out.back().check = names(field);
  };
  pose("ok", json{{"pose", {{"position", {1, 2, 3}}, {"quaternion", {0, 0, 0, 2}}}}}.dump(), Expect::ok, "");
  out.back().check = unit_pose;
  pose("quaternion_1e308", json{{"pose", {{"quaternion", {1e308, -1e308, 1e308, 1e308}}}}}.dump(), Expect::ok, "");
  out.back().check = unit_pose;
  pose("quaternion_tiny", json{{"pose", {{"quaternion", {1e-200, 1e-200, 0, 0}}}}}.dump(), Expect::client, "pose.quaternion");
  pose("position_1e999", "{\"pose\":{\"position\":[1e999,0,0]}}", Expect::client, "pose.position[0]");
  pose("position_nan_token", "{\"pose\":{\"position\":[NaN,0,0]}}", Expect::client, "");
  pose("missing", "{}", Expect::client, "pose");
  pose("not_object", "[1]", Expect::client, "");
  pose("empty_body", "", Expect::client, "");
  pose("unknown_item", json{{"pose", {{"position", {0, 0, 0}}}}}.dump(), Expect::client, "name", "/api/scene/items/nothing/pose");
  out.back().expect = Expect::status;
  out.back().status = 404;
  pose("bad_name", json{{"pose", {{"position", {0, 0, 0}}}}}.dump(), Expect::client, "name", "/api/scene/items/a%20b/pose");
  mutate_body(out, "scene/pose_mut", "PUT", pose_target, {{"pose", {{"position", {0.1, 0.2, 0.3}}, {"quaternion", {1, 0, 0, 0}}}}});
  out.push_back(api("scene/delete_unknown_item", "DELETE", "/api/scene/items/nothing", "", Expect::status));
  out.back().status = 404;
  out.back().check = names("name", "unknown_item");
  out.push_back(api("scene/delete_bad_name", "DELETE", "/api/scene/items/" + std::string(100, 'x'), "", Expect::client));
  out.back().check = names("name");
  out.push_back(api("scene/list_ok", "GET", "/api/scene/items", "", Expect::ok));

  // Recordings: the request.
  auto rec = [&](std::string name, json body, Expect e, std::string field, std::string code = "") {
    out.push_back(api("scene/recording_" + name, "POST", "/api/scene/recordings", body.dump(), e));
    if (e != Expect::ok && e != Expect::any) out.back().check = names(field, code);
  };
  const json png = {{"view", "gap"}, {"format", "png"}, {"frames", 2}};
  rec("ok", png, Expect::ok, "");
  // A duration whose frame count (seconds * fps) no integer holds: the count was cast to one (UB;
  // the message said "-9223372036854775808 frames").
  for (const auto& [label, seconds, fps] : std::vector<std::tuple<std::string, double, double>>{
           {"1e300", 1e300, 30}, {"1e18_fps_60", 1e18, 60}, {"max_double_fps_60", std::numeric_limits<double>::max(), 60}}) {
    rec("seconds_" + label, {{"view", "gap"}, {"format", "webm"}, {"seconds", seconds}, {"fps", fps}}, Expect::status, "seconds", "too_long");
    out.back().status = 413;
    out.back().check = [named = out.back().check](const Reply& r, Ctx& c) -> std::string {
      const json j = json::parse(r.body, nullptr, false);
      const std::string message = j.is_object() && j.contains("error") ? j["error"].value("message", "") : "";
      return named(r, c) + (message.find("-9") == std::string::npos ? "" : " a negative count in \"" + message + "\";");
    };
  }
  rec("frames_1e300", {{"view", "gap"}, {"format", "png"}, {"frames", 1e300}}, Expect::client, "frames");
  rec("frames_over", {{"view", "gap"}, {"format", "png"}, {"frames", kRecordFrames + 1}}, Expect::status, "frames", "too_long");
  out.back().status = 413;
  rec("frames_fraction", {{"view", "gap"}, {"format", "png"}, {"frames", 1.5}}, Expect::client, "frames");
  rec("fps_tiny", {{"view", "gap"}, {"format", "png"}, {"frames", 1}, {"fps", 1e-300}}, Expect::status, "frames", "too_long");
  out.back().status = 413;
  rec("fps_over", {{"view", "gap"}, {"format", "png"}, {"frames", 1}, {"fps", 1000}}, Expect::status, "fps", "too_fast");
  out.back().status = 413;
  rec("seconds_and_frames", {{"view", "gap"}, {"format", "png"}, {"frames", 1}, {"seconds", 1}}, Expect::client, "seconds");
  rec("neither", {{"view", "gap"}, {"format", "png"}}, Expect::client, "seconds");
  rec("view_plots", with(png, "view", "plots"), Expect::client, "view");
  rec("view_all", with(png, "view", "all"), Expect::client, "view");
  rec("format_gif", with(png, "format", "gif"), Expect::client, "format");
  mutate_body(out, "scene/recording_mut", "POST", "/api/scene/recordings", {{"view", "gap"}, {"format", "png"}, {"frames", 2}, {"fps", 10}});

  // Recordings: parts and ends, each on a fresh recording of 2 PNG frames.
  auto on_recording = [&](std::string name, std::function<std::string(Ctx&, const std::string&)> request, Expect e, std::string field, int status = 0) {
    out.push_back(make(
        "scene/" + name, [request](Ctx& c) {
          const json r = json::parse(call(c, "POST", "/api/scene/recordings", json{{"view", "gap"}, {"format", "png"}, {"frames", 2}}.dump(), c.session).body, nullptr, false);
          return request(c, r.is_object() && r.contains("id") ? r["id"].get<std::string>() : "none");
        },
        e));
    out.back().status = status;
    if (e != Expect::ok) out.back().check = names(field);
  };
  auto part = [](Ctx& c, const std::string& id, int i) { return call(c, "PUT", "/api/scene/recordings/" + id + "/parts/" + std::to_string(i), "PNG", c.session); };
  for (const auto& [label, index] : std::vector<std::pair<std::string, std::string>>{
           {"text", "abc"}, {"negative", "-1"}, {"huge", "99999999999"}, {"fraction", "0.5"}, {"plus", "%2B0"}, {"ahead", "1"}}) {
    const std::string i = index;
    on_recording(
        "part_index_" + label, [i](Ctx& c, const std::string& id) { return http("PUT", "/api/scene/recordings/" + id + "/parts/" + i, "PNG", c.session); },
        Expect::client, "index");
  }
  on_recording(
      "part_beyond_frames", [part](Ctx& c, const std::string& id) {
        part(c, id, 0);
        part(c, id, 1);
        return http("PUT", "/api/scene/recordings/" + id + "/parts/2", "PNG", c.session);
      },
      Expect::client, "index");
  on_recording(
      "part_empty", [](Ctx& c, const std::string& id) { return http("PUT", "/api/scene/recordings/" + id + "/parts/0", "", c.session); },
      Expect::client, "body");
  on_recording(
      "part_declared_over_limit", [](Ctx& c, const std::string& id) {
        return "PUT /api/scene/recordings/" + id + "/parts/0 HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\nX-Distlab-Session: " + c.session +
               "\r\nContent-Length: " + std::to_string(kRecordBytes + 1) + "\r\n\r\n";
      },
      Expect::status, "", 413);
  out.back().check = {};
  on_recording(
      "parts_over_bytes", [](Ctx& c, const std::string& id) {
        call(c, "PUT", "/api/scene/recordings/" + id + "/parts/0", std::string(kRecordBytes / 2 + 1, 'x'), c.session);
        return http("PUT", "/api/scene/recordings/" + id + "/parts/1", std::string(kRecordBytes / 2, 'x'), c.session);
      },
      Expect::status, "body", 413);
  on_recording(
      "part_after_finish", [](Ctx& c, const std::string& id) {
        call(c, "POST", "/api/scene/recordings/" + id + "/finish", json{{"error", "gave up"}}.dump(), c.session);
        return http("PUT", "/api/scene/recordings/" + id + "/parts/0", "PNG", c.session);
      },
      Expect::status, "id", 409);
  on_recording(
      "finish_twice", [](Ctx& c, const std::string& id) {
        call(c, "POST", "/api/scene/recordings/" + id + "/finish", json{{"error", "gave up"}}.dump(), c.session);
        return http("POST", "/api/scene/recordings/" + id + "/finish", json{{"error", "again"}}.dump(), c.session);
      },
      Expect::status, "id", 409);
  on_recording(
      "finish_parts_missing", [part](Ctx& c, const std::string& id) {
        part(c, id, 0);
        return http("POST", "/api/scene/recordings/" + id + "/finish", "{}", c.session);
      },
      Expect::client, "id");
  std::vector<double> m15(15, 0.0), m16(16, 0.0);
  const std::vector<std::pair<std::string, std::pair<json, std::string>>> finishes = {
      {"matrix_15", {{{"camera", {{"matrix", m15}, {"width", 10}, {"height", 10}}}}, "camera.matrix"}},
      {"matrix_1e999", {json::object(), "camera.matrix[3]"}},
      {"width_zero", {{{"camera", {{"matrix", m16}, {"width", 0}, {"height", 10}}}}, "camera.width"}},
      {"width_huge", {{{"camera", {{"matrix", m16}, {"width", 1e9}, {"height", 10}}}}, "camera.width"}},
      {"height_string", {{{"camera", {{"matrix", m16}, {"width", 10}, {"height", "10"}}}}, "camera.height"}},
      {"camera_unknown_key", {{{"camera", {{"matrix", m16}, {"width", 10}, {"height", 10}, {"fov", 1}}}}, "camera.fov"}},
      {"camera_not_object", {{{"camera", "front"}}, "camera"}},
      {"error_number", {{{"error", 5}}, "error"}},
      {"unknown_key", {{{"done", true}}, "done"}}};
  for (const auto& [label, spec] : finishes) {
    std::string body = spec.first.dump();
    if (label == "matrix_1e999") body = "{\"camera\":{\"matrix\":[0,0,0,1e999,0,0,0,0,0,0,0,0,0,0,0,0],\"width\":10,\"height\":10}}";
    on_recording(
        "finish_" + label, [part, body](Ctx& c, const std::string& id) {
          part(c, id, 0);
          part(c, id, 1);
          return http("POST", "/api/scene/recordings/" + id + "/finish", body, c.session);
        },
        Expect::client, spec.second);
  }
  on_recording(
      "finish_error_long_ok", [](Ctx& c, const std::string& id) {
        return http("POST", "/api/scene/recordings/" + id + "/finish", json{{"error", std::string(10000, 'e')}}.dump(), c.session);
      },
      Expect::ok, "");
  on_recording(
      "part_get_missing", [](Ctx& c, const std::string& id) { return http("GET", "/api/scene/recordings/" + id + "/parts/5", "", c.session); },
      Expect::status, "index", 404);
  on_recording(
      "part_get_text", [](Ctx& c, const std::string& id) { return http("GET", "/api/scene/recordings/" + id + "/parts/x", "", c.session); },
      Expect::client, "index");
  out.push_back(api("scene/recording_unknown_get", "GET", "/api/scene/recordings/0000", "", Expect::status));
  out.back().status = 404;
  out.back().check = names("id", "unknown_recording");
  out.push_back(api("scene/recording_unknown_delete", "DELETE", "/api/scene/recordings/0000", "", Expect::status));
  out.back().status = 404;
  out.back().check = names("id", "unknown_recording");
  out.push_back(api("scene/clear_ok", "DELETE", "/api/scene/items", "", Expect::ok));
}

}  // namespace distlab::test::hostile
