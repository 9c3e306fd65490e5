// Held triangles (uploads.hpp).
#include "distlab/server/uploads.hpp"

#include <string>

#include "distlab/server/http.hpp"

namespace distlab::server {

HeldTriangles::Reservation& HeldTriangles::Reservation::operator=(Reservation&& o) noexcept {
  if (this != &o) {
    release();
    counts_ = std::move(o.counts_);
    address_ = std::move(o.address_);
    triangles_ = o.triangles_;
    o.triangles_ = 0;
  }
  return *this;
}

void HeldTriangles::Reservation::release() noexcept {
  if (!counts_ || triangles_ == 0) return;
  std::lock_guard lock(counts_->mutex);
  counts_->total -= triangles_;
  if (auto it = counts_->by_address.find(address_); it != counts_->by_address.end() && (it->second -= triangles_) == 0)
    counts_->by_address.erase(it);
  triangles_ = 0;
}

HeldTriangles::Reservation HeldTriangles::reserve(const std::string& address, std::size_t triangles, const std::string& field) {
  std::lock_guard lock(counts_->mutex);
  const auto it = counts_->by_address.find(address);
  const std::size_t mine = it == counts_->by_address.end() ? 0 : it->second;
  if (mine + triangles > per_address_)
    throw ApiError(413, "too_many_held_triangles",
                   "this client holds " + std::to_string(mine) + " triangles in uploads and objects and at most " + std::to_string(per_address_) +
                       " are kept per client address; delete uploads or objects (DELETE /api/kelvin/uploads/{id}, /api/kelvin/objects/{id}) to make room for " +
                       std::to_string(triangles),
                   field);
  if (counts_->total + triangles > total_)
    throw ApiError(503, "busy", "the server holds its most triangles for its clients (" + std::to_string(total_) + "); try again later", field);
  counts_->total += triangles;
  counts_->by_address[address] = mine + triangles;
  return {counts_, address, triangles};
}

}  // namespace distlab::server
