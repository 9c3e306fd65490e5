// Client shares (client_share.hpp).
#include "distlab/server/client_share.hpp"

#include <string>

#include "distlab/server/http.hpp"

namespace distlab::server {

ClientShare::Reservation& ClientShare::Reservation::operator=(Reservation&& o) noexcept {
  if (this != &o) {
    release();
    counts_ = std::move(o.counts_);
    address_ = std::move(o.address_);
    amount_ = o.amount_;
    o.amount_ = 0;
  }
  return *this;
}

void ClientShare::Reservation::release() noexcept {
  if (!counts_ || amount_ == 0) return;
  std::lock_guard lock(counts_->mutex);
  counts_->total -= amount_;
  if (auto it = counts_->by_address.find(address_); it != counts_->by_address.end() && (it->second -= amount_) == 0)
    counts_->by_address.erase(it);
  amount_ = 0;
}

ClientShare::Reservation ClientShare::reserve(const std::string& address, std::size_t amount, const std::string& field) {
  std::lock_guard lock(counts_->mutex);
  const auto it = counts_->by_address.find(address);
  const std::size_t mine = it == counts_->by_address.end() ? 0 : it->second;
  if (mine + amount > per_address_)
    throw ApiError(413, "too_much_held",
                   "this client holds " + std::to_string(mine) + " " + unit_ + " and at most " + std::to_string(per_address_) + " are kept per client address (" +
                       per_address_limit_ + "); delete " + to_delete_ + " to make room for " + std::to_string(amount),
                   field);
  if (counts_->total + amount > total_)
    throw ApiError(503, "busy", "the server holds its most " + unit_ + " for its clients (" + std::to_string(total_) + ", " + total_limit_ + "); try again later", field);
  counts_->total += amount;
  counts_->by_address[address] = mine + amount;
  return {counts_, address, amount};
}

}  // namespace distlab::server
