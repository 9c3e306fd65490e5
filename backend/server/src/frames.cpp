#include "distlab/server/frames.hpp"

#include <cstring>

namespace distlab::server {

using json = nlohmann::json;
static_assert(sizeof(float) == 4, "float32 frames");

namespace {
template <class T>
void put(json::binary_t& out, T v) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, &v, sizeof(T));
  // The wire format is little-endian; so is every platform distlab targets (x86-64, arm64).
  out.insert(out.end(), b, b + sizeof(T));
}
}  // namespace

json::binary_t float32_bytes(const double* values, std::size_t count) {
  json::binary_t out;
  out.reserve(count * 4);
  for (std::size_t i = 0; i < count; ++i) put(out, static_cast<float>(values[i]));
  return out;
}

json::binary_t float32_bytes(const std::vector<double>& values) { return float32_bytes(values.data(), values.size()); }

json scalars_frame(const std::vector<double>& scalars, json meta) {
  json frame = std::move(meta);
  if (!frame.is_object()) frame = json::object();
  frame["n_vertices"] = scalars.size();
  frame["scalars"] = json::binary(float32_bytes(scalars));
  return frame;
}

json mesh_frame(const mesh::SurfaceMesh& m, json meta, const std::vector<double>* scalars) {
  json::binary_t pos, idx;
  pos.reserve(static_cast<std::size_t>(m.vertices.rows()) * 12);
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v)
    for (int c = 0; c < 3; ++c) put(pos, static_cast<float>(m.vertices(v, c)));
  idx.reserve(static_cast<std::size_t>(m.faces.rows()) * 12);
  for (Eigen::Index f = 0; f < m.faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) put(idx, static_cast<std::uint32_t>(m.faces(f, c)));
  json frame = std::move(meta);
  if (!frame.is_object()) frame = json::object();
  frame["n_vertices"] = m.vertices.rows();
  frame["n_faces"] = m.faces.rows();
  frame["positions"] = json::binary(std::move(pos));
  frame["indices"] = json::binary(std::move(idx));
  if (scalars != nullptr) frame["scalars"] = json::binary(float32_bytes(*scalars));
  return frame;
}

std::string to_msgpack(const json& frame) {
  std::string out;
  json::to_msgpack(frame, nlohmann::detail::output_adapter<char>(out));
  return out;
}

std::vector<float> read_float32(const json& bin) {
  const auto& b = bin.get_binary();
  std::vector<float> out(b.size() / 4);
  if (!out.empty()) std::memcpy(out.data(), b.data(), out.size() * 4);
  return out;
}

std::vector<std::uint32_t> read_uint32(const json& bin) {
  const auto& b = bin.get_binary();
  std::vector<std::uint32_t> out(b.size() / 4);
  if (!out.empty()) std::memcpy(out.data(), b.data(), out.size() * 4);
  return out;
}

}  // namespace distlab::server
