#include "distlab/server/session.hpp"

#include "distlab/server/http.hpp"

namespace distlab::server {
namespace {
std::int64_t now_ms() {
  return std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

void Session::touch() { last_seen_ = now_ms(); }
double Session::idle_seconds() const { return static_cast<double>(now_ms() - last_seen_.load()) / 1000.0; }

void Session::broadcast(const std::string& data, bool binary, const WsSink* except) {
  std::vector<std::shared_ptr<WsSink>> live;
  {
    std::lock_guard lock(mutex);
    for (auto it = sockets.begin(); it != sockets.end();) {
      if (auto s = it->lock()) {
        if (s.get() != except) live.push_back(std::move(s));
        ++it;
      } else {
        it = sockets.erase(it);
      }
    }
  }
  for (auto& s : live) s->send(data, binary);
}

std::shared_ptr<Session> SessionStore::create() {
  std::lock_guard lock(mutex_);
  if (sessions_.size() >= max_sessions_) sweep_locked();
  if (sessions_.size() >= max_sessions_)
    throw ApiError(429, "too_many_sessions", "the server has reached its session limit; try again later");
  std::string id;
  do id = random_id();
  while (sessions_.count(id));
  auto s = std::make_shared<Session>(id);
  sessions_.emplace(id, s);
  return s;
}

std::shared_ptr<Session> SessionStore::find(const std::string& id) {
  std::lock_guard lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return nullptr;
  it->second->touch();
  return it->second;
}

void SessionStore::erase(const std::string& id) {
  std::lock_guard lock(mutex_);
  sessions_.erase(id);
}

std::size_t SessionStore::size() const {
  std::lock_guard lock(mutex_);
  return sessions_.size();
}

std::vector<std::shared_ptr<Session>> SessionStore::all() const {
  std::lock_guard lock(mutex_);
  std::vector<std::shared_ptr<Session>> out;
  for (const auto& [id, s] : sessions_) out.push_back(s);
  return out;
}

void SessionStore::sweep_locked() {
  for (auto it = sessions_.begin(); it != sessions_.end();) {
    bool has_socket = false;
    {
      std::lock_guard lock(it->second->mutex);
      for (const auto& w : it->second->sockets) has_socket = has_socket || !w.expired();
    }
    if (!has_socket && it->second->idle_seconds() > idle_seconds_)
      it = sessions_.erase(it);
    else
      ++it;
  }
}

}  // namespace distlab::server
