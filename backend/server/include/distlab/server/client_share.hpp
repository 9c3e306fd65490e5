#pragma once
// What the server holds for its clients (uploads' and objects' triangles, scene items' and
// recordings' bytes), counted per client address and in all: a reservation is taken before the
// memory is, and gives its amount back when it is destroyed with whatever holds it. Over the
// address's share a request is refused with 413, over the server's total with 503. Thread-safe.
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace distlab::server {

class ClientShare {
 public:
  struct Counts {
    std::mutex mutex;
    std::map<std::string, std::size_t> by_address;
    std::size_t total = 0;
  };
  class Reservation {
   public:
    Reservation() = default;
    Reservation(std::shared_ptr<Counts> counts, std::string address, std::size_t amount)
        : counts_(std::move(counts)), address_(std::move(address)), amount_(amount) {}
    Reservation(Reservation&& o) noexcept { *this = std::move(o); }
    Reservation& operator=(Reservation&& o) noexcept;
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    ~Reservation() { release(); }

   private:
    void release() noexcept;
    std::shared_ptr<Counts> counts_;
    std::string address_;
    std::size_t amount_ = 0;
  };

  // unit: "triangles" or "bytes"; the limits' names and what the client can delete, for messages.
  ClientShare(std::string unit, std::string per_address_limit, std::size_t per_address, std::string total_limit, std::size_t total,
              std::string to_delete)
      : unit_(std::move(unit)),
        per_address_limit_(std::move(per_address_limit)),
        total_limit_(std::move(total_limit)),
        to_delete_(std::move(to_delete)),
        per_address_(per_address),
        total_(total) {}
  // ApiError 413 naming `field` when the address would hold more than its share, 503 when the
  // server would hold more than its total.
  Reservation reserve(const std::string& address, std::size_t amount, const std::string& field);

 private:
  std::string unit_, per_address_limit_, total_limit_, to_delete_;
  std::size_t per_address_, total_;
  std::shared_ptr<Counts> counts_ = std::make_shared<Counts>();
};

}  // namespace distlab::server
