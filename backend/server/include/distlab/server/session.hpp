#pragma once
// Client sessions: an unguessable id (POST /api/session) owns every client resource (the
// modules' state, such as Kelvin's uploads and objects, jobs and their results, WebSocket
// connections). Lookups always go through the owner's session, so another client's id is simply
// not found (404).
#include <atomic>
#include <chrono>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>
#include <typeindex>
#include <vector>

namespace distlab::server {

// One WebSocket connection, as seen by the service (thread-safe).
class WsSink {
 public:
  virtual ~WsSink() = default;
  virtual void send(std::string data, bool binary) = 0;
  virtual void close() = 0;
};

// What a module keeps per session (module.hpp), derived from this: the session holds one of each
// type and drops it with itself; the core never looks inside.
struct ModuleState {
  virtual ~ModuleState() = default;
};

class Session {
 public:
  Session(std::string session_id, std::string client_address)
      : id(std::move(session_id)), address(std::move(client_address)) { touch(); }
  const std::string id;
  const std::string address;  // the client address that created it (its per-address quota)

  std::mutex mutex;  // guards the modules' states and the socket list
  std::vector<std::weak_ptr<WsSink>> sockets;
  // A socket that joins is listed at once but sent its hello first: what the session broadcasts
  // before the hello waits here, and is sent right after it (finish_join).
  void start_join(const std::shared_ptr<WsSink>& socket);
  void finish_join(WsSink& socket, const std::string& hello);  // an empty hello: none (an error)

  // The module state of type T, made empty on first use. Call with `mutex` held.
  template <class T>
  T& state() {
    static_assert(std::is_base_of_v<ModuleState, T>);
    std::unique_ptr<ModuleState>& slot = states_[std::type_index(typeid(T))];
    if (!slot) slot = std::make_unique<T>();
    return static_cast<T&>(*slot);
  }

  void touch();
  double idle_seconds() const;
  bool has_socket();  // an open WebSocket (locks)
  // Sends to every open socket of this session (text JSON or binary msgpack), but `except`.
  void broadcast(const std::string& data, bool binary, const WsSink* except = nullptr);

 private:
  std::mutex joining_;  // held while a broadcast sends and while a hello and what waited are sent
  std::map<const WsSink*, std::vector<std::pair<std::string, bool>>> waiting_;
  std::atomic<std::int64_t> last_seen_{0};
  std::map<std::type_index, std::unique_ptr<ModuleState>> states_;
};

// Sessions are bounded in total and per client address, so that one client cannot deny the
// others: a client at its address's quota loses its own least recently used session; a full
// store first drops sessions idle past idle_seconds, then the least recently used session of the
// address holding the most. Sessions with an open WebSocket are never evicted.
class SessionStore {
 public:
  SessionStore(std::size_t max_sessions, std::size_t max_per_address, double idle_seconds)
      : max_sessions_(max_sessions), max_per_address_(max_per_address), idle_seconds_(idle_seconds) {}
  // Throws ApiError 429 when no session can be evicted for it.
  std::shared_ptr<Session> create(const std::string& address);
  std::shared_ptr<Session> find(const std::string& id);  // nullptr if unknown
  void erase(const std::string& id);
  std::size_t size() const;
  std::vector<std::shared_ptr<Session>> all() const;

 private:
  void sweep_locked();
  // Evicts the least recently used session without a socket among those of `address` (any
  // address when nullptr); false if there is none.
  bool evict_lru_locked(const std::string* address);
  void erase_locked(std::map<std::string, std::shared_ptr<Session>>::iterator it);
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<Session>> sessions_;
  std::map<std::string, std::size_t> per_address_;  // sessions held by each client address
  std::size_t max_sessions_, max_per_address_;
  double idle_seconds_;
};

}  // namespace distlab::server
