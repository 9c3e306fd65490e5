#pragma once
// Starts the real `distlab serve` (port 0: it prints the port it got) with a temporary cache and
// web directory, waits for /api/health, and stops it with SIGTERM, expecting a clean exit (a
// sanitizer report or a crash fails the test). Plus a small Beast WebSocket client.
#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <httplib.h>
#include <boost/asio/connect.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/websocket.hpp>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "temp_dir.hpp"

namespace distlab::test {

using json = nlohmann::json;
namespace fs = std::filesystem;

class ServerProcess {
 public:
  // extra: more `distlab serve` options (limits). cache_dir "" makes a fresh one. max_open_files:
  // the server's RLIMIT_NOFILE (0: inherited); a test that exhausts the server's descriptors sets
  // it, so that sanitized runs know (ubsan_no_descriptors.supp).
  explicit ServerProcess(std::vector<std::string> extra = {}, std::string cache_dir = "", rlim_t max_open_files = 0)
      : max_open_files_(max_open_files) {
    ::signal(SIGPIPE, SIG_IGN);  // a server closing on a refused upload must not kill the test
    cache_dir_ = cache_dir.empty() ? own_cache_.emplace("distlab-test-cache").path() : cache_dir;
    web_root_.write("web/index.html", "<!doctype html><title>distlab test</title>\n");
    web_root_.write("web/js/app.js", "console.log('distlab');\n");
    web_root_.write("web-secret.txt", "secret\n");  // beside the web folder: never served
    web_dir_ = (web_root_ / "web").string();
    start(std::move(extra));
  }
  // The server stops before the members remove its folders.
  ~ServerProcess() {
    if (pid_ > 0) stop();
  }
  ServerProcess(const ServerProcess&) = delete;
  ServerProcess& operator=(const ServerProcess&) = delete;

  int port() const { return port_; }
  pid_t pid() const { return pid_; }
  const std::string& cache_dir() const { return cache_dir_; }
  const std::string& web_dir() const { return web_dir_; }
  httplib::Client client() const {
    httplib::Client c("127.0.0.1", port_);
    c.set_read_timeout(120, 0);
    c.set_write_timeout(60, 0);
    return c;
  }

  // SIGTERM and wait; returns the exit status (0 expected).
  int stop() {
    if (pid_ <= 0) return -1;
    ::kill(pid_, SIGTERM);
    int status = 0;
    for (int i = 0; i < 300; ++i) {  // 30 s
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        pid_ = -1;
        if (out_) std::fclose(out_);
        out_ = nullptr;
        return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, &status, 0);
    pid_ = -1;
    return 137;
  }

 private:
  void start(std::vector<std::string> extra) {
    std::vector<std::string> args = {DISTLAB_EXE, "serve", "--host", "127.0.0.1", "--port", "0",
                                     "--cache-dir", cache_dir_, "--web", web_dir_,
                                     "--assets", std::string(DISTLAB_SOURCE_DIR) + "/assets", "--threads", "2"};
    args.insert(args.end(), extra.begin(), extra.end());
    int fds[2];
    ASSERT_EQ(::pipe(fds), 0);
    pid_ = ::fork();
    ASSERT_GE(pid_, 0);
    if (pid_ == 0) {
      // Sanitized builds: known third-party leaks only (see lsan.supp).
      const std::string lsan = "suppressions=" + std::string(DISTLAB_SOURCE_DIR) + "/tests/server/lsan.supp";
      ::setenv("LSAN_OPTIONS", lsan.c_str(), 0);
      if (max_open_files_ > 0) {
        const rlimit lim{max_open_files_, max_open_files_};
        ::setrlimit(RLIMIT_NOFILE, &lim);
        // UBSan's vptr check cannot work without a free descriptor (ubsan_no_descriptors.supp).
        const char* ubsan = std::getenv("UBSAN_OPTIONS");
        const std::string options = std::string(ubsan != nullptr ? ubsan : "") + ":suppressions=" +
                                    std::string(DISTLAB_SOURCE_DIR) + "/tests/server/ubsan_no_descriptors.supp";
        ::setenv("UBSAN_OPTIONS", options.c_str(), 1);
      }
      ::dup2(fds[1], 1);
      ::close(fds[0]);
      ::close(fds[1]);
      std::vector<char*> argv;
      for (auto& a : args) argv.push_back(a.data());
      argv.push_back(nullptr);
      ::execv(argv[0], argv.data());
      ::_exit(127);
    }
    ::close(fds[1]);
    out_ = ::fdopen(fds[0], "r");
    char line[1024] = {0};
    ASSERT_NE(std::fgets(line, sizeof line, out_), nullptr) << "the server printed nothing";
    const std::string s = line;
    const auto colon = s.find("127.0.0.1:");
    ASSERT_NE(colon, std::string::npos) << s;
    port_ = std::stoi(s.substr(colon + 10));
    auto c = client();
    for (int i = 0; i < 100; ++i) {
      if (auto r = c.Get("/api/health"); r && r->status == 200) return;
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
    FAIL() << "no /api/health";
  }

  rlim_t max_open_files_ = 0;
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
  int port_ = 0;
  std::optional<TempDir> own_cache_;  // when no cache folder is given
  TempDir web_root_{"distlab-test-web"};
  std::string cache_dir_, web_dir_;
};

// One server per test suite: started before its first test, stopped after its last, which must
// be a clean exit. `class Suite : public SharedServerTest<Suite>`; a suite that needs options (limits)
// declares `static std::vector<std::string> server_options()`.
template <class Suite>
class SharedServerTest : public ::testing::Test {
 protected:
  static std::vector<std::string> server_options() { return {}; }
  static void SetUpTestSuite() { server_ = new ServerProcess(Suite::server_options()); }
  static void TearDownTestSuite() {
    EXPECT_EQ(server_->stop(), 0) << "the server did not exit cleanly";
    delete server_;
    server_ = nullptr;
  }
  static inline ServerProcess* server_ = nullptr;
  httplib::Client c = server_->client();
};

inline json body_json(const httplib::Result& r) {
  if (!r) return json();
  return json::parse(r->body, nullptr, false);
}

inline std::string new_session(httplib::Client& c) {
  auto r = c.Post("/api/session", "", "application/json");
  if (!r || r->status != 201) return "";
  return body_json(r)["session"].get<std::string>();
}

inline httplib::Headers session_headers(const std::string& id) { return {{"X-Distlab-Session", id}}; }

// An error answer: `status` and {"error": {code, message, field}} with a message; code and field
// as given unless "*". `line`: the caller's, in the failure messages.
inline void expect_error(const httplib::Result& r, int status, const std::string& code, const std::string& field = "*",
                         int line = __builtin_LINE()) {
  SCOPED_TRACE("expect_error at line " + std::to_string(line));
  ASSERT_TRUE(r) << "no response";
  EXPECT_EQ(r->status, status) << r->body;
  const json j = body_json(r);
  ASSERT_TRUE(j.is_object() && j.contains("error")) << r->body;
  if (code != "*") {
    EXPECT_EQ(j["error"]["code"], code) << r->body;
  }
  EXPECT_TRUE(j["error"]["message"].is_string() && !j["error"]["message"].get<std::string>().empty()) << r->body;
  if (field != "*") {
    EXPECT_EQ(j["error"]["field"], field) << r->body;
  }
}

// GET path as session s, expecting `status`; the body as JSON.
inline json get_json(httplib::Client& c, const std::string& s, const std::string& path, int status = 200) {
  auto r = c.Get(path, session_headers(s));
  EXPECT_TRUE(r);
  if (!r) return json();
  EXPECT_EQ(r->status, status) << path << ": " << r->body;
  return body_json(r);
}

// A blocking WebSocket client with timeouts (Boost.Beast).
class WsClient {
 public:
  // The throw the check finds is nlohmann::json's unreachable internal-error branch of its noexcept
  // default constructor.
  struct Message {  // NOLINT(bugprone-exception-escape)
    std::string data;
    bool binary = false;
    json j;  // parsed: JSON text or msgpack
  };

  WsClient(int port, const std::string& session) : ws_(ioc_) {
    namespace net = boost::asio;
    net::ip::tcp::resolver resolver(ioc_);
    auto results = resolver.resolve("127.0.0.1", std::to_string(port));
    boost::beast::get_lowest_layer(ws_).connect(results);
    ws_.handshake("127.0.0.1:" + std::to_string(port), "/ws?session=" + session);
  }

  void send(const json& j) { ws_.write(boost::asio::buffer(j.dump())); }
  void send_raw(const std::string& s) { ws_.write(boost::asio::buffer(s)); }
  void send_binary(const std::string& s) {
    ws_.binary(true);
    ws_.write(boost::asio::buffer(s));
    ws_.binary(false);
  }

  // Next message, or false after timeout seconds / on close (error() then says why).
  bool read(Message& m, double timeout = 30) {
    boost::beast::flat_buffer buffer;
    bool done = false;
    error_ = {};
    boost::beast::get_lowest_layer(ws_).expires_after(std::chrono::milliseconds(static_cast<long>(timeout * 1000)));
    ws_.async_read(buffer, [&](boost::beast::error_code ec, std::size_t) {
      error_ = ec;
      done = true;
    });
    ioc_.restart();
    ioc_.run();
    if (!done || error_) return false;
    m.data = boost::beast::buffers_to_string(buffer.data());
    m.binary = ws_.got_binary();
    m.j = m.binary ? json::from_msgpack(m.data, true, false) : json::parse(m.data, nullptr, false);
    return true;
  }

  // Reads until pred(message) holds; false on timeout/close.
  bool until(const std::function<bool(const Message&)>& pred, Message& out, double timeout = 60) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(static_cast<long>(timeout * 1000));
    while (std::chrono::steady_clock::now() < end) {
      const double left = std::chrono::duration<double>(end - std::chrono::steady_clock::now()).count();
      if (!read(out, std::max(0.01, left))) return false;
      if (pred(out)) return true;
    }
    return false;
  }

  boost::beast::error_code error() const { return error_; }
  boost::beast::websocket::close_reason close_reason() const { return ws_.reason(); }

 private:
  boost::asio::io_context ioc_;
  boost::beast::websocket::stream<boost::beast::tcp_stream> ws_;
  boost::beast::error_code error_;
};

// Waits for the socket's "hello": from then on the server has registered it, so the session's
// broadcasts and job events reach it (a socket still registering could miss them).
inline void await_hello(WsClient& ws) {
  WsClient::Message m;
  ASSERT_TRUE(ws.until([](const WsClient::Message& x) { return !x.binary && x.j["type"] == "hello"; }, m, 60)) << "no hello";
}

// Raw HTTP over a socket, for requests a client library would normalise (traversal attempts).
inline std::string raw_http(int port, const std::string& request) {
  namespace net = boost::asio;
  net::io_context ioc;
  net::ip::tcp::socket s(ioc);
  s.connect({net::ip::make_address("127.0.0.1"), static_cast<unsigned short>(port)});
  net::write(s, net::buffer(request));
  std::string out;
  boost::system::error_code ec;
  char buf[4096];
  for (;;) {
    const std::size_t n = s.read_some(net::buffer(buf), ec);
    out.append(buf, n);
    if (ec) break;
  }
  return out;
}

inline int raw_status(const std::string& response) {
  if (response.size() < 12) return 0;
  return std::atoi(response.substr(9, 3).c_str());
}

}  // namespace distlab::test
