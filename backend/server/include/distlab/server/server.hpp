#pragma once
// The network side: one port (Boost.Beast) for the REST API, static files and the WebSocket at
// /ws. I/O threads only parse and write; heavy routes run on the service's compute pool.
#include <memory>
#include <string>

#include "distlab/server/service.hpp"

namespace distlab::server {

class HttpServer {
 public:
  // Binds immediately (throws std::runtime_error if it cannot); port 0 picks a free port.
  HttpServer(Service& service, const std::string& host, unsigned short port, unsigned io_threads = 0);
  ~HttpServer();
  unsigned short port() const;
  // Serves until stop() (from any thread or a signal handler context via asio) or SIGINT/SIGTERM
  // when handle_signals is set. Returns after the I/O threads have finished.
  void run(bool handle_signals = true);
  void stop();

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace distlab::server
