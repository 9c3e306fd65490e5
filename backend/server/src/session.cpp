#include "distlab/server/session.hpp"

#include <algorithm>

#include "distlab/server/http.hpp"

namespace distlab::server {
namespace {
// Nanoseconds, so that sessions created one after the other are ordered (LRU eviction).
std::int64_t now_ns() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now().time_since_epoch()).count();
}
}  // namespace

void Session::touch() { last_seen_ = now_ns(); }

bool Session::has_socket() {
  std::lock_guard lock(mutex);
  for (const auto& w : sockets)
    if (!w.expired()) return true;
  return false;
}
double Session::idle_seconds() const { return static_cast<double>(now_ns() - last_seen_.load()) * 1e-9; }

void Session::start_join(const std::shared_ptr<WsSink>& socket) {
  std::lock_guard joining(joining_);
  std::lock_guard lock(mutex);
  if (std::none_of(sockets.begin(), sockets.end(), [&](const auto& w) { return w.lock() == socket; })) sockets.push_back(socket);
  waiting_.try_emplace(socket.get());
}

void Session::finish_join(WsSink& socket, const std::string& hello) {
  std::lock_guard joining(joining_);
  if (!hello.empty()) socket.send(hello, false);
  if (auto it = waiting_.find(&socket); it != waiting_.end()) {
    for (const auto& [data, binary] : it->second) socket.send(data, binary);
    waiting_.erase(it);
  }
}

void Session::broadcast(const std::string& data, bool binary, const WsSink* except) {
  std::lock_guard joining(joining_);
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
  for (auto& s : live) {
    if (auto it = waiting_.find(s.get()); it != waiting_.end())
      it->second.emplace_back(data, binary);
    else
      s->send(data, binary);
  }
}

std::shared_ptr<Session> SessionStore::create(const std::string& address) {
  std::lock_guard lock(mutex_);
  const auto held = [&](const std::string& a) {
    const auto it = per_address_.find(a);
    return it == per_address_.end() ? std::size_t{0} : it->second;
  };
  if (held(address) >= max_per_address_ && !evict_lru_locked(&address))
    throw ApiError(429, "too_many_sessions",
                   "this address holds " + std::to_string(held(address)) + " sessions with open sockets (max_sessions_per_address)");
  if (sessions_.size() >= max_sessions_) sweep_locked();
  if (sessions_.size() >= max_sessions_) {
    const std::string* biggest = nullptr;
    for (const auto& [a, n] : per_address_)
      if (biggest == nullptr || n > held(*biggest)) biggest = &a;
    if (!evict_lru_locked(biggest) && !evict_lru_locked(nullptr))
      throw ApiError(429, "too_many_sessions", "the server has reached its session limit; try again later");
  }
  std::string id;
  do id = random_id();
  while (sessions_.count(id));
  auto s = std::make_shared<Session>(id, address);
  sessions_.emplace(id, s);
  ++per_address_[address];
  return s;
}

bool SessionStore::evict_lru_locked(const std::string* address) {
  auto victim = sessions_.end();
  double idlest = -1;
  for (auto it = sessions_.begin(); it != sessions_.end(); ++it) {
    if (address != nullptr && it->second->address != *address) continue;
    const double idle = it->second->idle_seconds();
    if (idle > idlest && !it->second->has_socket()) {
      idlest = idle;
      victim = it;
    }
  }
  if (victim == sessions_.end()) return false;
  erase_locked(victim);
  return true;
}

void SessionStore::erase_locked(std::map<std::string, std::shared_ptr<Session>>::iterator it) {
  const auto a = per_address_.find(it->second->address);
  if (a != per_address_.end() && --a->second == 0) per_address_.erase(a);
  sessions_.erase(it);
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
  if (const auto it = sessions_.find(id); it != sessions_.end()) erase_locked(it);
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
    auto next = std::next(it);
    if (it->second->idle_seconds() > idle_seconds_ && !it->second->has_socket()) erase_locked(it);
    it = next;
  }
}

}  // namespace distlab::server
