// Boost.Beast listener, HTTP connections and WebSocket connections.
#include "distlab/server/server.hpp"

#include <algorithm>
#include <atomic>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <deque>
#include <optional>
#include <thread>

namespace distlab::server {

namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
namespace net = boost::asio;
using tcp = net::ip::tcp;

namespace {

constexpr std::size_t kHeaderLimit = 16 * 1024;

std::chrono::steady_clock::duration read_timeout(const Service& service) {
  return std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(service.config().limits.read_timeout_seconds));
}

// One open connection counted against max_connections for as long as it is held (the HTTP
// connection, then its WebSocket).
class ConnectionSlot {
 public:
  explicit ConnectionSlot(std::atomic<std::size_t>& open) : open_(open) {}
  ~ConnectionSlot() { --open_; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;

 private:
  std::atomic<std::size_t>& open_;
};

std::string lower(std::string s) {
  for (auto& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

Request to_request(const http::request<http::string_body>& req, const tcp::socket& socket) {
  Request r;
  beast::error_code ec;
  const auto remote = socket.remote_endpoint(ec);
  if (!ec) r.remote_address = remote.address().to_string();
  r.method = std::string(req.method_string());
  r.target = std::string(req.target());
  split_target(r.target, r.path, r.query, &r.repeated_query);
  for (const auto& f : req) r.headers[lower(std::string(f.name_string()))] = std::string(f.value());
  r.body = req.body();
  return r;
}

http::response<http::string_body> to_beast(const Response& res, unsigned version, bool keep_alive, bool head) {
  http::response<http::string_body> out{static_cast<http::status>(res.status), version};
  out.set(http::field::server, "distlab");
  if (!res.content_type.empty()) out.set(http::field::content_type, res.content_type);
  for (const auto& [k, v] : res.headers) out.set(k, v);
  out.set("X-Content-Type-Options", "nosniff");
  out.keep_alive(keep_alive);
  if (head) {
    out.content_length(res.body.size());
  } else {
    out.body() = res.body;
    out.prepare_payload();
  }
  return out;
}

// ---------------------------------------------------------------------------------------------

class WsConnection : public WsSink, public std::enable_shared_from_this<WsConnection> {
 public:
  WsConnection(tcp::socket&& socket, Service& service, std::shared_ptr<Session> session,
               std::shared_ptr<ConnectionSlot> slot)
      : ws_(std::move(socket)), service_(service), session_(std::move(session)), slot_(std::move(slot)), tokens_(service.config().limits.ws_burst), last_refill_(std::chrono::steady_clock::now()) {}

  // async_accept builds its response from req before it returns: a reference suffices.
  void start(const http::request<http::string_body>& req) {
    beast::get_lowest_layer(ws_).expires_never();
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.set_option(websocket::stream_base::decorator(
        [](websocket::response_type& res) { res.set(http::field::server, "distlab"); }));
    ws_.read_message_max(service_.config().limits.max_ws_message_bytes);
    ws_.async_accept(req, beast::bind_front_handler(&WsConnection::on_accept, shared_from_this()));
  }

  void send(std::string data, bool binary) override {
    net::post(ws_.get_executor(), [self = shared_from_this(), data = std::move(data), binary]() mutable {
      if (self->closed_ || self->close_code_) return;
      if (self->queue_.size() >= self->service_.config().limits.max_ws_queue) {
        // A client that does not read: drop it rather than grow without bound.
        self->request_close(websocket::close_code::policy_error);
        return;
      }
      self->queue_.emplace_back(std::move(data), binary);
      if (!self->writing_) self->do_write();
    });
  }

  void close() override {
    net::post(ws_.get_executor(), [self = shared_from_this()] { self->request_close(websocket::close_code::going_away); });
  }

 private:
  void on_accept(beast::error_code ec) {
    if (ec) return;
    accepted_ = true;
    service_.ws_open(session_, shared_from_this());
    do_read();
  }

  void do_read() {
    ws_.async_read(buffer_, beast::bind_front_handler(&WsConnection::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    if (ec) {  // closed, or failed (Beast itself answers an oversized message with close 1009)
      closed_ = true;
      queue_.clear();
      return;
    }
    // Token bucket: rate and burst from the limits; an empty bucket answers an error, and a
    // client that keeps going far past it is disconnected.
    const Limits& lim = service_.config().limits;
    const auto now = std::chrono::steady_clock::now();
    tokens_ = std::min(lim.ws_burst, tokens_ + std::chrono::duration<double>(now - last_refill_).count() * lim.ws_messages_per_second);
    last_refill_ = now;
    const std::string data = beast::buffers_to_string(buffer_.data());
    const bool binary = ws_.got_binary();
    buffer_.consume(buffer_.size());
    if (tokens_ >= 1) {
      tokens_ -= 1;
      refused_ = 0;
      auto self = shared_from_this();
      service_.ws_message(session_, self, data, binary);
    } else if (++refused_ > std::max<std::size_t>(50, static_cast<std::size_t>(10 * lim.ws_burst))) {
      request_close(websocket::close_code::policy_error);
      return;
    } else {
      nlohmann::json e{{"type", "error"}, {"status", 429}, {"error", {{"code", "rate_limited"}, {"message", "too many WebSocket messages; slow down"}, {"field", ""}}}};
      // The refused message's request id, so that its sender can tell which request failed.
      if (!binary)
        if (nlohmann::json id = Service::request_id(data); !id.is_null()) e["request"] = std::move(id);
      send(e.dump(), false);
    }
    do_read();
  }

  // One write at a time; a close waits for the write in flight (a close is a write too).
  void do_write() {
    if (queue_.empty() || closed_) return;
    writing_ = true;
    ws_.binary(queue_.front().second);
    ws_.async_write(net::buffer(queue_.front().first), beast::bind_front_handler(&WsConnection::on_write, shared_from_this()));
  }

  void on_write(beast::error_code ec, std::size_t) {
    writing_ = false;
    if (ec) {
      closed_ = true;
      queue_.clear();
      return;
    }
    if (!queue_.empty()) queue_.pop_front();
    if (close_code_) return start_close();
    do_write();
  }

  void request_close(websocket::close_code code) {
    if (closed_ || close_code_) return;
    close_code_ = code;
    if (!writing_) start_close();
  }

  void start_close() {
    queue_.clear();
    if (closed_ || !accepted_) return;
    closed_ = true;
    ws_.async_close(*close_code_, [self = shared_from_this()](beast::error_code) {});
  }

  websocket::stream<beast::tcp_stream> ws_;
  beast::flat_buffer buffer_;
  Service& service_;
  std::shared_ptr<Session> session_;
  std::shared_ptr<ConnectionSlot> slot_;
  std::deque<std::pair<std::string, bool>> queue_;
  bool closed_ = false, accepted_ = false, writing_ = false;
  std::optional<websocket::close_code> close_code_;
  double tokens_;
  std::size_t refused_ = 0;
  std::chrono::steady_clock::time_point last_refill_;
};

// ---------------------------------------------------------------------------------------------

class HttpConnection : public std::enable_shared_from_this<HttpConnection> {
 public:
  HttpConnection(tcp::socket&& socket, Service& service, std::shared_ptr<ConnectionSlot> slot)
      : stream_(std::move(socket)), service_(service), slot_(std::move(slot)) {}

  void start() { net::dispatch(stream_.get_executor(), beast::bind_front_handler(&HttpConnection::do_read, shared_from_this())); }

 private:
  void do_read() {
    parser_.emplace();
    parser_->header_limit(kHeaderLimit);
    parser_->body_limit(service_.config().limits.max_upload_bytes);
    // The whole header must arrive within the timeout (an idle or slowloris client is closed).
    stream_.expires_after(read_timeout(service_));
    http::async_read_header(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpConnection::on_header, shared_from_this()));
  }

  void on_header(beast::error_code ec, std::size_t) {
    if (ec == http::error::end_of_stream) return do_shutdown();
    if (ec == http::error::header_limit) return fail_and_close(431, "header_too_large", "request headers are too large");
    if (ec == http::error::body_limit)
      return fail_and_close(413, "body_too_large", "the request body exceeds the limit");
    if (ec) {
      if (ec != beast::error::timeout && ec != net::error::operation_aborted && ec != net::error::connection_reset)
        return fail_and_close(400, "bad_request", "malformed HTTP request");
      return;
    }
    auto& req = parser_->get();
    if (websocket::is_upgrade(req)) {
      Request r = to_request(req, stream_.socket());
      Response refusal;
      auto session = service_.ws_authorize(r, refusal);
      if (!session) return fail_and_close(refusal.status, refusal.body);
      stream_.expires_never();
      std::make_shared<WsConnection>(stream_.release_socket(), service_, session, slot_)->start(parser_->release());
      return;
    }
    std::string path;
    std::map<std::string, std::string> query;
    split_target(std::string(req.target()), path, query);
    limit_ = service_.body_limit(path);
    if (req.has_content_length() || req.chunked()) {
      const auto length = parser_->content_length();
      if (length && *length > limit_)
        return fail_and_close(413, "body_too_large", "the request body exceeds " + std::to_string(limit_) + " bytes");
      parser_->body_limit(limit_);
    }
    stream_.expires_after(read_timeout(service_));  // and the body within the timeout too
    http::async_read(stream_, buffer_, *parser_, beast::bind_front_handler(&HttpConnection::on_read, shared_from_this()));
  }

  void on_read(beast::error_code ec, std::size_t) {
    if (ec == http::error::body_limit)
      return fail_and_close(413, "body_too_large", "the request body exceeds " + std::to_string(limit_) + " bytes");
    if (ec) {
      if (ec != beast::error::timeout && ec != net::error::operation_aborted && ec != http::error::end_of_stream)
        return fail_and_close(400, "bad_request", "malformed HTTP request");
      return;
    }
    auto req = parser_->release();
    auto request = std::make_shared<Request>(to_request(req, stream_.socket()));
    const unsigned version = req.version();
    const bool keep_alive = req.keep_alive();
    const bool head = req.method() == http::verb::head;
    if (!service_.heavy(*request)) {
      const Response res = service_.handle(*request);
      return write(to_beast(res, version, keep_alive, head));
    }
    stream_.expires_never();
    auto self = shared_from_this();
    const bool posted = service_.post_compute([self, request, version, keep_alive, head] {
      Response res = self->service_.handle(*request);
      net::post(self->stream_.get_executor(), [self, res = std::move(res), version, keep_alive, head] {
        self->write(to_beast(res, version, keep_alive, head));
      });
    });
    if (!posted)
      write(to_beast(error_response(503, "busy", "the server is busy; try again shortly"), version, keep_alive, head));
  }

  void fail_and_close(int status, const std::string& code, const std::string& message) {
    fail_and_close(status, error_response(status, code, message).body);
  }
  void fail_and_close(int status, const std::string& body) {
    Response r;
    r.status = status;
    r.body = body;
    write(to_beast(r, 11, false, false));
  }

  void write(http::response<http::string_body>&& res) {
    auto sp = std::make_shared<http::response<http::string_body>>(std::move(res));
    response_ = sp;
    stream_.expires_after(read_timeout(service_));
    http::async_write(stream_, *sp, [self = shared_from_this(), sp](beast::error_code ec, std::size_t) {
      self->response_.reset();
      if (ec) return;
      if (!sp->keep_alive()) return self->do_shutdown();
      self->do_read();
    });
  }

  void do_shutdown() {
    beast::error_code ec;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ec);
  }

  beast::tcp_stream stream_;
  beast::flat_buffer buffer_;
  Service& service_;
  std::optional<http::request_parser<http::string_body>> parser_;
  std::shared_ptr<void> response_;
  std::size_t limit_ = 0;
  std::shared_ptr<ConnectionSlot> slot_;
};

}  // namespace

// ---------------------------------------------------------------------------------------------

struct HttpServer::Impl {
  Service& service;
  net::io_context ioc;
  tcp::acceptor acceptor;
  unsigned threads;
  std::atomic<bool> stopping{false};
  std::thread stopper;
  std::atomic<std::size_t> open{0};  // connections held (max_connections)
  net::steady_timer backoff;         // accepting again after running out of descriptors
  std::chrono::milliseconds pause{0};

  Impl(Service& s, unsigned n)
      : service(s), ioc(static_cast<int>(n)), acceptor(net::make_strand(ioc)), threads(n), backoff(acceptor.get_executor()) {}

  void accept() {
    acceptor.async_accept(net::make_strand(ioc), [this](beast::error_code ec, tcp::socket socket) {
      if (ec == net::error::operation_aborted || !acceptor.is_open()) return;
      if (ec == net::error::no_descriptors || ec == net::error::no_buffer_space || ec == net::error::no_memory ||
          ec.value() == ENFILE) {
        // The pending connection stays queued, so accepting again at once fails again (a busy
        // loop): wait, 10 ms doubling to 1 s, until a descriptor is free.
        pause = std::min(std::chrono::milliseconds(1000), std::max(std::chrono::milliseconds(10), 2 * pause));
        backoff.expires_after(pause);
        backoff.async_wait([this](beast::error_code wait_ec) {
          if (!wait_ec && acceptor.is_open()) accept();
        });
        return;
      }
      pause = std::chrono::milliseconds(0);
      if (!ec) {
        if (open.fetch_add(1) >= service.config().limits.max_connections) {
          --open;  // over the cap: closed at once (the socket's destructor)
          beast::error_code ignored;
          socket.shutdown(tcp::socket::shutdown_both, ignored);
        } else {
          auto slot = std::make_shared<ConnectionSlot>(open);
          // Small messages (σ acknowledgements, frames' headers) must not wait for a delayed ACK.
          beast::error_code nd;
          socket.set_option(tcp::no_delay(true), nd);
          std::make_shared<HttpConnection>(std::move(socket), service, std::move(slot))->start();
        }
      }
      accept();
    });
  }
};

HttpServer::HttpServer(Service& service, const std::string& host, unsigned short port, unsigned io_threads) {
  if (io_threads == 0) io_threads = std::max(2u, std::thread::hardware_concurrency());
  impl_ = std::make_unique<Impl>(service, io_threads);
  beast::error_code ec;
  const auto address = net::ip::make_address(host, ec);
  if (ec) throw std::runtime_error("invalid host address \"" + host + "\"");
  const tcp::endpoint endpoint(address, port);
  auto& a = impl_->acceptor;
  a.open(endpoint.protocol(), ec);
  if (!ec) a.set_option(net::socket_base::reuse_address(true), ec);
  if (!ec) a.bind(endpoint, ec);
  if (!ec) a.listen(net::socket_base::max_listen_connections, ec);
  if (ec) throw std::runtime_error("cannot listen on " + host + ":" + std::to_string(port) + ": " + ec.message());
}

HttpServer::~HttpServer() {
  stop();
  if (impl_->stopper.joinable()) impl_->stopper.join();
}

unsigned short HttpServer::port() const { return impl_->acceptor.local_endpoint().port(); }

void HttpServer::run(bool handle_signals) {
  Impl& m = *impl_;
  net::signal_set signals(m.ioc);
  if (handle_signals) {
    signals.add(SIGINT);
    signals.add(SIGTERM);
    signals.async_wait([this](beast::error_code ec, int) {
      if (!ec) stop();
    });
  }
  m.accept();
  std::vector<std::thread> pool;
  for (unsigned i = 1; i < m.threads; ++i) pool.emplace_back([&m] { m.ioc.run(); });
  m.ioc.run();
  for (auto& t : pool) t.join();
  if (m.stopper.joinable()) m.stopper.join();
}

void HttpServer::stop() {
  if (!impl_) return;
  Impl& m = *impl_;
  if (m.stopping.exchange(true)) return;
  net::post(m.acceptor.get_executor(), [&m] {
    beast::error_code ec;
    m.acceptor.close(ec);
    m.backoff.cancel();
  });
  // Finish the service's work first (jobs are cancelled, sockets get a close frame), then give
  // pending writes a moment before the loop stops.
  m.stopper = std::thread([&m] {
    m.service.shutdown();
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    m.ioc.stop();
  });
}

}  // namespace distlab::server
