#pragma once
// The meshes a session uploaded (POST /api/kelvin/uploads), by upload id. Their bytes were parsed
// in an isolated child process (mesh/isolated_import.hpp) when they arrived: every module that
// takes an upload id (Kelvin objects, a robot's URDF meshes) reads the parsed surface from here
// and never parses the bytes itself.
#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "distlab/mesh/surface.hpp"
#include "distlab/server/session.hpp"

namespace distlab::server {

struct Upload {
  mesh::SurfaceMesh surface;  // the file's vertices in its order, times the upload's unit or scale
  std::string format;
  std::size_t bytes = 0;
  std::string unit;  // "m", "cm", "mm", "in", or "" when a scale was given
  double scale = 1;  // metres per file unit
  // SHA-256 of `surface` (the Kelvin module's mesh_digest): what a link names the mesh by.
  std::string digest;
};

// The triangles the server holds for its clients, counted per client address and in all
// (Limits::max_held_triangles_per_address, max_held_triangles): a reservation is taken before the
// memory is, and gives its triangles back when it is destroyed with whatever holds it (an upload's
// session entry, a Kelvin object). Thread-safe.
class HeldTriangles {
 public:
  struct Counts {
    std::mutex mutex;
    std::map<std::string, std::size_t> by_address;
    std::size_t total = 0;
  };
  class Reservation {
   public:
    Reservation() = default;
    Reservation(std::shared_ptr<Counts> counts, std::string address, std::size_t triangles)
        : counts_(std::move(counts)), address_(std::move(address)), triangles_(triangles) {}
    Reservation(Reservation&& o) noexcept { *this = std::move(o); }
    Reservation& operator=(Reservation&& o) noexcept;
    Reservation(const Reservation&) = delete;
    Reservation& operator=(const Reservation&) = delete;
    ~Reservation() { release(); }

   private:
    void release() noexcept;
    std::shared_ptr<Counts> counts_;
    std::string address_;
    std::size_t triangles_ = 0;
  };

  HeldTriangles(std::size_t per_address, std::size_t total) : per_address_(per_address), total_(total) {}
  // ApiError 413 naming `field` when the address would hold more than its share, 503 when the
  // server would hold more than its total.
  Reservation reserve(const std::string& address, std::size_t triangles, const std::string& field);

 private:
  std::size_t per_address_, total_;
  std::shared_ptr<Counts> counts_ = std::make_shared<Counts>();
};

// A session's uploads (Session::state, guarded by the session's mutex), at most
// Limits::max_uploads_per_session, each with its reservation of held triangles.
struct SessionUploads : ModuleState {
  std::map<std::string, std::shared_ptr<const Upload>> uploads;
  std::map<std::string, HeldTriangles::Reservation> held;
};

}  // namespace distlab::server
