// The field store's listing, checks and collection as JSON (kelvin_json.hpp): `distlab cache`
// prints it, distlab.cache returns it.
#include "distlab/kelvin/store.hpp"
#include "distlab/server/kelvin_json.hpp"

namespace distlab::server {

using json = nlohmann::json;

json cache_ls_json(const std::string& dir) {
  const kelvin::StoreListing l = kelvin::list_store(dir);
  json entries = json::array(), leases = json::array();
  for (const kelvin::StoreEntry& e : l.entries) {
    json j = {{"name", e.name}, {"bytes", e.bytes}, {"last_used", e.last_used}, {"current", e.current}, {"format", e.format}};
    if (e.current && e.readable) {
      j["lx"] = e.lx;
      j["far_radius"] = e.far_radius;
      j["feature_angle"] = e.feature_angle;
      j["grading"] = e.grading < 0 ? json(nullptr) : json(e.grading);
      j["center"] = {e.centre[0], e.centre[1], e.centre[2]};
      j["surface_vertices"] = e.surface_vertices;
      j["surface_faces"] = e.surface_faces;
      j["n_verts"] = e.n_verts;
      j["n_tets"] = e.n_tets;
    } else {
      j["current"] = false;
    }
    entries.push_back(std::move(j));
  }
  for (const kelvin::StoreLease& s : l.leases)
    leases.push_back({{"name", s.name}, {"host", s.host}, {"pid", s.pid}, {"started", s.started}, {"renewed", s.renewed}, {"lease_seconds", s.lease_seconds}, {"state", s.state}});
  return {{"dir", dir}, {"bytes", l.bytes}, {"entries", entries}, {"leases", leases}, {"temporaries", l.temporaries}};
}

json cache_verify_json(const std::string& dir, bool fix) {
  json entries = json::array();
  long ok = 0, bad = 0, removed = 0;
  for (const kelvin::VerifiedEntry& v : kelvin::verify_store(dir, fix)) {
    (v.status == "ok" ? ok : bad) += 1;
    removed += v.removed ? 1 : 0;
    entries.push_back({{"name", v.name}, {"bytes", v.bytes}, {"status", v.status}, {"removed", v.removed}});
  }
  return {{"dir", dir}, {"entries", entries}, {"ok", ok}, {"bad", bad}, {"removed", removed}};
}

json cache_gc_json(const kelvin::FieldStore& store) {
  const kelvin::GcReport r = kelvin::gc_store(store);
  return {{"dir", store.dir},
          {"budget", store.budget_bytes > 0 ? json(store.budget_bytes) : json(nullptr)},
          {"keep_recent_seconds", store.keep_recent_seconds},
          {"bytes_before", r.bytes_before},
          {"bytes_after", r.bytes_after},
          {"evicted", r.evicted},
          {"kept_recent", r.kept_recent},
          {"removed", r.removed}};
}

}  // namespace distlab::server
