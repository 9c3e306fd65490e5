#pragma once
// Client sessions: an unguessable id (POST /api/session) owns every client resource (uploads,
// Kelvin objects with their σ, jobs and their results, WebSocket connections). Lookups always go
// through the owner's session, so another client's id is simply not found (404).
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "distlab/mesh/surface.hpp"

namespace distlab::server {

// One WebSocket connection, as seen by the service (thread-safe).
class WsSink {
 public:
  virtual ~WsSink() = default;
  virtual void send(std::string data, bool binary) = 0;
  virtual void close() = 0;
};

struct KelvinObject;  // kelvin_objects.hpp

struct Upload {
  mesh::SurfaceMesh surface;
  std::string format;
  std::size_t bytes = 0;
};

class Session {
 public:
  explicit Session(std::string session_id) : id(std::move(session_id)) { touch(); }
  const std::string id;

  std::mutex mutex;  // guards the maps and the socket list
  std::map<std::string, std::shared_ptr<KelvinObject>> objects;
  std::map<std::string, std::shared_ptr<Upload>> uploads;
  std::vector<std::weak_ptr<WsSink>> sockets;

  void touch();
  double idle_seconds() const;
  // Sends to every open socket of this session (text JSON or binary msgpack), but `except`.
  void broadcast(const std::string& data, bool binary, const WsSink* except = nullptr);

 private:
  std::atomic<std::int64_t> last_seen_{0};
};

class SessionStore {
 public:
  SessionStore(std::size_t max_sessions, double idle_seconds)
      : max_sessions_(max_sessions), idle_seconds_(idle_seconds) {}
  // Throws ApiError 429 when full (after dropping idle sessions).
  std::shared_ptr<Session> create();
  std::shared_ptr<Session> find(const std::string& id);  // nullptr if unknown
  void erase(const std::string& id);
  std::size_t size() const;
  std::vector<std::shared_ptr<Session>> all() const;

 private:
  void sweep_locked();
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Session>> sessions_;
  std::size_t max_sessions_;
  double idle_seconds_;
};

}  // namespace distlab::server
