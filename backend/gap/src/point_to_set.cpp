// Weak and strict point-to-set functions (GAP paper, Sections III-B and III-C).
//
// Weak e_S per shape (each satisfies Definition 1 with >= 0 in Property 2):
// - polytope/box, eq. (5): Σ W_i Φ(a_i·p − b_i); ‖∂²e‖ <= Σ_violated W_i Φ'' < m W_i < 1; above
//   kAreaWeightedRows rows and for every hull of points W_i ∝ facet area + mean area, scaled by
//   max_violated_eigenvalue_bound to the same end.
// - sphere: Φ(‖p‖ − r). Hessian Φ'' nnᵀ + Φ'/‖p‖ (I − nnᵀ); Φ' <= s < ‖p‖, so both parts < 1.
// - cylinder: Φ(‖p_xy‖ − r) + Φ(z − l/2) + Φ(−z − l/2); the radial, tangential and axial parts
//   act on orthogonal directions, so m = 1: round shapes get the weight 1/(1 + margin).
// - capsule: the infimal convolution min_t [Φ(‖p − t e_z‖ − r) + Φ(|t| − l/2)] of a ball's and
//   a segment's functions. Its zero set is exactly the capsule; it is convex; by the implicit
//   function theorem (the t-curvature is > 0 outside the set) it is as smooth as Φ; and its
//   Hessian is a Schur complement of the ball's, so it stays below I. (Φ(dist − r) would only be
//   C¹ across the planes z = ±l/2.)
#include "distlab/gap/point_to_set.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#ifdef __SSE2__
#include <emmintrin.h>
#endif

#include "distlab/geometry/error.hpp"
#include "distlab/geometry/overloaded.hpp"
#include "exact_key_cache.hpp"

namespace distlab {
namespace {

// Adds W Φ(s) along unit direction u (s = u·p − b), for a term whose Hessian is rank one.
template <class T>
inline void add_linear_term(P2SValueT<T>& v, const BaseFunction& phi, T w, T s, const Vec3T<T>& u,
                            int order) {
  if (!(s > 0)) return;
  const auto j = phi.jet_as(s);
  v.value += w * j.value;
  if (order >= 1) v.gradient += (w * j.d1) * u;
  if (order >= 2) v.hessian.noalias() += (w * j.d2) * u * u.transpose();
}

// Φ(‖q‖ − r) for q = p (sphere) or q = (x, y, 0) (cylinder, `planar`).
template <class T>
inline void add_radial_term(P2SValueT<T>& v, const BaseFunction& phi, const Vec3T<T>& q, T r,
                            bool planar, int order) {
  const T n2 = q.squaredNorm();
  if (!(n2 > r * r)) return;
  const T norm = std::sqrt(n2);
  const auto j = phi.jet_as(norm - r);
  v.value += j.value;
  if (order < 1) return;
  const Vec3T<T> n = q / norm;
  v.gradient += j.d1 * n;
  if (order < 2) return;
  Mat3T<T> P = Mat3T<T>::Identity();  // projector onto the space q lives in
  if (planar) P(2, 2) = 0;
  v.hessian.noalias() += j.d2 * n * n.transpose() + (j.d1 / norm) * (P - n * n.transpose());
}

template <class T>
P2SValueT<T> scaled(P2SValueT<T> v, T w) {
  v.value *= w;
  v.gradient *= w;
  v.hessian *= w;
  return v;
}

// Largest distance from c to a point of the shape (shape frame).
double farthest_distance(const Shape& shape, const Vec3& c) {
  return std::visit(
      Overloaded{
          [&](const Polytope& poly) {
            double d = 0;
            for (const auto& v : poly.vertices) d = std::max(d, (v - c).norm());
            return d;
          },
          [&](const Box& box) {
            const Vec3 far = c.cwiseAbs() + box.size / 2;  // the corner opposite to c
            return far.norm();
          },
          [&](const Sphere& s) { return c.norm() + s.radius; },
          [&](const Cylinder& cyl) {
            const double radial = std::hypot(c.x(), c.y()) + cyl.radius;
            return std::hypot(radial, std::abs(c.z()) + cyl.height / 2);
          },
          [&](const Capsule& cap) {
            return (c - Vec3(0, 0, c.z() > 0 ? -cap.height / 2 : cap.height / 2)).norm() +
                   cap.radius;
          }},
      shape);
}

// Eq. (6) in a form without cancellation: with A = ερ, B = σe, V = sqrt(A² + B²),
// E = A + V = B²/(V − A) when A < 0; ∇E = (E∇A + B∇B)/V;
// ∂²E = (E ∂²A + B ∂²B)/V + q qᵀ/V³ with q = A∇B − B∇A (eq. 18).
// Internal linkage, one caller per scalar: inlined into strict() as when it was written there.
template <class T>
P2SValueT<T> strict_from_weak(const P2SValueT<T>& e, const Vec3T<T>& p, const StrictParams& strict, const Ball& rho,
                              const Vec3T<T>& rho_center, int order) {
  const T eps = strict.eps, sigma = strict.sigma, radius = rho.radius;
  const Vec3T<T> dc = p - rho_center;
  const T A = eps * T(0.5) * (dc.squaredNorm() - radius * radius);
  const T B = sigma * e.value;
  const T V = std::sqrt(A * A + B * B);  // both are far from overflow here
  P2SValueT<T> out;
  out.value = A >= 0 ? A + V : B * B / (V - A);
  if (order < 1) return out;
  const T inv_v = T(1) / V;
  const Vec3T<T> dA = eps * dc;
  const Vec3T<T> dB = sigma * e.gradient;
  out.gradient = (out.value * inv_v) * dA + (B * inv_v) * dB;
  if (order < 2) return out;
  const Vec3T<T> q = A * dB - B * dA;
  out.hessian.noalias() = (B * sigma * inv_v) * e.hessian + (inv_v * inv_v * inv_v) * q * q.transpose();
  out.hessian.diagonal().array() += out.value * eps * inv_v;
  return out;
}

// A mesh's hull: m grows with the facet count, and 1/m weakens a large flat facet as much as a
// sliver (a Kinova base's caps: Property 2 fails near the ρ sphere beyond them). Half the weight
// goes by facet area, which follows the surface the facets approximate, half uniformly, which
// keeps finely tessellated tips from vanishing; K, the bound of Σ_violated w_i a_i a_iᵀ, keeps
// ∂²e_S < I as m does. Cached: K costs seconds on thousands of facets.
std::size_t vector_bytes(const VecX& v) { return sizeof(double) * static_cast<std::size_t>(v.size()); }
using HullWeightCache = detail::ExactKeyCache<VecX, vector_bytes>;

HullWeightCache& hull_weight_cache() {
  static HullWeightCache c(kHullWeightCacheBytes);
  return c;
}

VecX hull_weights(const Polytope& poly, double margin) {
  using detail::append_bytes;
  std::string key;  // everything the weights are computed from: rows, vertices, faces, margin
  append_bytes(key, margin);
  const std::size_t rows = static_cast<std::size_t>(poly.A.rows()), faces = poly.faces.size();
  append_bytes(key, &rows, sizeof rows);
  append_bytes(key, poly.A.data(), sizeof(double) * 3 * rows);
  append_bytes(key, &faces, sizeof faces);
  append_bytes(key, poly.faces.data(), sizeof(Eigen::Vector3i) * faces);
  append_bytes(key, poly.vertices.data(), sizeof(Vec3) * poly.vertices.size());
  VecX weights;
  if (hull_weight_cache().find(key, weights)) return weights;
  const VecX area = facet_areas(poly);
  const VecX w = area.array() + area.mean();
  weights = w / (max_violated_eigenvalue_bound(poly.A, w) * (1 + margin));
  hull_weight_cache().insert(key, weights);
  return weights;
}

}  // namespace

CacheStats hull_weight_cache_stats() { return hull_weight_cache().stats(); }
void clear_hull_weight_cache() { hull_weight_cache().clear(); }

PointToSet::PointToSet(const Shape& shape, const BaseFunction& phi, const StrictParams& strict,
                       const P2SOptions& options, const std::string& field)
    : shape_(shape), phi_(phi), strict_(strict) {
  if (const auto* poly = std::get_if<Polytope>(&shape_)) {
    A_local_ = poly->A;
    b_local_ = poly->b;
  } else if (const auto* box = std::get_if<Box>(&shape_)) {
    box_halfspaces(*box, A_local_, b_local_);
  }
  const auto rows = A_local_.rows();
  if (options.round_weight && rows > 0)
    throw InvalidInput(field + ".round_weight", "round_weight applies only to round shapes");
  if (options.weights) {
    if (rows == 0)
      throw InvalidInput(field + ".weights", "weights apply only to polytopes and boxes");
    if (options.weights->size() != rows)
      throw InvalidInput(field + ".weights", "expected " + std::to_string(rows) +
                                                 " weights (one per half-space), got " +
                                                 std::to_string(options.weights->size()));
    for (Eigen::Index i = 0; i < rows; ++i) {
      const double w = (*options.weights)[i];
      if (!std::isfinite(w) || w <= 0)
        throw InvalidInput(field + ".weights[" + std::to_string(i) + "]",
                           "weights must be finite and > 0");
    }
    weights_ = *options.weights;
  } else if (rows > 0) {
    if (!std::isfinite(options.weight_margin) || options.weight_margin <= 0)
      throw InvalidInput("params.weight_margin", "weight_margin must be finite and > 0");
    const auto* poly = std::get_if<Polytope>(&shape_);
    if (poly == nullptr || (!poly->is_hull && rows <= kAreaWeightedRows)) {
      weights_ = VecX::Constant(rows, 1.0 / (max_violated_halfspaces(A_local_) + options.weight_margin));
    } else {
      weights_ = hull_weights(*poly, options.weight_margin);
    }
  } else if (options.round_weight) {
    if (!(*options.round_weight > 0 && *options.round_weight <= 1))
      throw InvalidInput(field + ".round_weight", "round_weight must be in (0, 1]");
    round_weight_ = *options.round_weight;
  } else {
    // Round shapes: their terms act on orthogonal directions, so m = 1.
    round_weight_ = 1.0 / (1.0 + options.weight_margin);
  }

  const Ball bound = bounding_ball(shape_);
  if (options.rho) {
    rho_ = *options.rho;
    if (!rho_.center.allFinite())
      throw InvalidInput(field + ".rho.center", "rho.center must be 3 finite numbers");
    if (!std::isfinite(rho_.radius) || rho_.radius <= 0)
      throw InvalidInput(field + ".rho.radius", "rho.radius must be finite and > 0");
    // ρ must be negative on the whole shape (Theorem 2): the ball must strictly cover it.
    const double reach = farthest_distance(shape_, rho_.center);
    if (!(reach < rho_.radius))
      throw InvalidInput(field + ".rho.radius",
                         "the rho ball must strictly cover the shape: radius " +
                             std::to_string(rho_.radius) + " <= farthest shape point at " +
                             std::to_string(reach));
  } else {
    rho_ = {bound.center, bound.radius * kDefaultRhoScale};
  }
  if (!std::isfinite(strict_.eps) || strict_.eps <= 0)
    throw InvalidInput("params.eps", "eps must be finite and > 0");
  if (!std::isfinite(strict_.sigma) || strict_.sigma <= 0)
    throw InvalidInput("params.sigma", "sigma must be finite and > 0");
  set_pose(Pose{});
}

void PointToSet::set_pose(const Pose& pose) {
  pose_ = pose;
  R_ = pose.R();
  if (A_local_.rows() > 0) {
    A_world_ = A_local_ * R_.transpose();
    b_world_ = b_local_ + A_world_ * pose.position;
    const auto n = static_cast<size_t>(A_world_.rows());
    // Padded to an even count with a row never violated (0·p − 1 < 0).
    const size_t padded = n + n % 2;
    soa_.assign(kRowArrays * padded, 0.0);
    std::fill(soa_.begin() + static_cast<std::ptrdiff_t>(3 * padded), soa_.begin() + static_cast<std::ptrdiff_t>(4 * padded), 1.0);
    for (size_t i = 0; i < n; ++i) {
      const auto row = static_cast<Eigen::Index>(i);
      for (int q = 0; q < 3; ++q) soa_[q * padded + i] = A_world_(row, q);
      soa_[3 * padded + i] = b_world_[row];
      soa_[4 * padded + i] = weights_[row];
    }
  }
  rho_center_world_ = pose.to_world(rho_.center);
}

// Eq. (5) over the rows; only violated rows (s > 0) contribute, each a rank-one Hessian term
// Φ'' W u uᵀ. The s of two rows are computed at once (SSE2 lanes, the same operations and
// rounding as one at a time) from the structure-of-arrays rows (soa_). The violated rows are
// marked first without a branch (about a third of the rows are violated, at random: a branch per
// row mispredicted about once in three rows), then their terms are added in row order. The order
// is a template argument: no test of it per violated row.
namespace {

typedef double V2 __attribute__((vector_size(16), aligned(8)));  // unaligned loads

// Bit 0: s[0] > 0, bit 1: s[1] > 0 (one compare and movmskpd with SSE2).
inline std::uint64_t violated_pair(V2 s) {
#ifdef __SSE2__
  return static_cast<std::uint64_t>(_mm_movemask_pd(_mm_cmpgt_pd(s, _mm_setzero_pd())));
#else
  return std::uint64_t{s[0] > 0} | std::uint64_t{s[1] > 0} << 1;
#endif
}

// Eq. (5)'s sum over violated rows, to derivative order Order, in the order the rows are added:
// W Φ, W Φ' u and Φ'' W u uᵀ, W u uᵀ formed as (W u_i) u_j where a row is violated (the same
// products that were once stored per row).
template <int Order>
struct Sums {
  double value = 0, g[3] = {0, 0, 0}, h[6] = {0, 0, 0, 0, 0, 0};
  void add(double w, double ux, double uy, double uz, double phi, double d1, double d2) {
    value += w * phi;
    if constexpr (Order >= 1) {
      const double c = w * d1;
      g[0] += c * ux, g[1] += c * uy, g[2] += c * uz;
    }
    if constexpr (Order >= 2) {
      const double wx = w * ux, wy = w * uy, wz = w * uz;
      h[0] += d2 * (wx * ux), h[1] += d2 * (wx * uy), h[2] += d2 * (wx * uz);
      h[3] += d2 * (wy * uy), h[4] += d2 * (wy * uz), h[5] += d2 * (wz * uz);
    }
  }
  P2SValue result() const {
    P2SValue v;
    v.value = value;
    v.gradient = Vec3(g[0], g[1], g[2]);
    v.hessian << h[0], h[1], h[2], h[1], h[3], h[4], h[2], h[4], h[5];
    return v;
  }
};

}  // namespace

template <int Order>
P2SValue PointToSet::halfspaces_world(const Vec3& p) const {
  Sums<Order> sums;
  const V2 px = {p.x(), p.x()}, py = {p.y(), p.y()}, pz = {p.z(), p.z()};
  const size_t padded = soa_.size() / kRowArrays;
  const double *ux = soa_.data(), *uy = ux + padded, *uz = uy + padded, *ub = uz + padded, *uw = ub + padded;
  // Rows in chunks of 64: one bit per violated row, their s kept beside.
  constexpr size_t kChunk = 64;
  alignas(16) double sv[kChunk];
  for (size_t start = 0; start < padded; start += kChunk) {
    const size_t count = std::min(padded - start, kChunk);
    std::uint64_t violated = 0;
    for (size_t i = 0; i < count; i += 2) {
      const size_t at = start + i;
      const V2 s = *reinterpret_cast<const V2*>(ux + at) * px + *reinterpret_cast<const V2*>(uy + at) * py +
                   *reinterpret_cast<const V2*>(uz + at) * pz - *reinterpret_cast<const V2*>(ub + at);
      *reinterpret_cast<V2*>(sv + i) = s;
      violated |= violated_pair(s) << i;  // a padding row is never violated
    }
    for (; violated; violated &= violated - 1) {
      const auto i = static_cast<size_t>(__builtin_ctzll(violated));
      const size_t at = start + i;
      const auto j = phi_.jet(sv[i]);
      sums.add(uw[at], ux[at], uy[at], uz[at], j.value, j.d1, j.d2);
    }
  }
  return sums.result();
}

unsigned PointToSet::violated_rows(const Vec3& p, double* s, unsigned* index) const {
  const V2 px = {p.x(), p.x()}, py = {p.y(), p.y()}, pz = {p.z(), p.z()};
  const size_t padded = soa_.size() / kRowArrays;
  const double *ux = soa_.data(), *uy = ux + padded, *uz = uy + padded, *ub = uz + padded;
  unsigned n = 0;
  for (size_t i = 0; i < padded; i += 2) {
    // The same operations as halfspaces_world; listed without a branch.
    const V2 si = *reinterpret_cast<const V2*>(ux + i) * px + *reinterpret_cast<const V2*>(uy + i) * py +
                  *reinterpret_cast<const V2*>(uz + i) * pz - *reinterpret_cast<const V2*>(ub + i);
    s[n] = si[0], index[n] = static_cast<unsigned>(i), n += si[0] > 0;
    s[n] = si[1], index[n] = static_cast<unsigned>(i + 1), n += si[1] > 0;  // a padding row is never violated
  }
  return n;
}

template <int Order>
P2SValue PointToSet::sum_rows(const unsigned* index, const Term* terms, unsigned count) const {
  Sums<Order> sums;
  const size_t padded = soa_.size() / kRowArrays;
  const double *ux = soa_.data(), *uy = ux + padded, *uz = uy + padded, *uw = uz + 2 * padded;
  for (unsigned k = 0; k < count; ++k) {
    const unsigned i = index[k];
    sums.add(uw[i], ux[i], uy[i], uz[i], terms[k].value, terms[k].d1, terms[k].d2);
  }
  return sums.result();
}

void PointToSet::strict_pair(const Vec3& p, const PointToSet& other, const Vec3& q, int order, P2SValue& out,
                             P2SValue& other_out) const {
  const size_t rows = soa_.size() / kRowArrays, other_rows = other.soa_.size() / kRowArrays;  // padded; 0: round
  if (rows == 0 || other_rows == 0 || rows > kPairRows || other_rows > kPairRows || !phi_.same_as(other.phi_)) {
    out = strict(p, order);
    other_out = other.strict(q, order);
    return;
  }
  double s[2 * kPairRows];
  unsigned index[2 * kPairRows];
  const unsigned n = violated_rows(p, s, index);
  const unsigned m = n + other.violated_rows(q, s + n, index + n);
  Term terms[2 * kPairRows];
  for (unsigned k = 0; k < m; ++k) {
    const auto j = phi_.jet(s[k]);
    terms[k] = {j.value, j.d1, j.d2};
  }
  const auto sum = [&](const PointToSet& set, const unsigned* at, const Term* t, unsigned count) {
    return order >= 2 ? set.sum_rows<2>(at, t, count) : order == 1 ? set.sum_rows<1>(at, t, count)
                                                                   : set.sum_rows<0>(at, t, count);
  };
  const P2SValue e = sum(*this, index, terms, n), other_e = sum(other, index + n, terms + n, m - n);
  out = strict_from_weak(e, p, strict_, rho_, rho_center_world_, order);
  other_out = strict_from_weak(other_e, q, other.strict_, other.rho_, other.rho_center_world_, order);
}

template <class T>
P2SValueT<T> PointToSet::capsule_local(const Vec3T<T>& p, int order) const {
  const auto& cap = std::get<Capsule>(shape_);
  const T r = cap.radius, half = T(cap.height) / 2;
  const T rho2 = p.x() * p.x() + p.y() * p.y();
  const T z = std::abs(p.z()), sign = p.z() < 0 ? -1 : 1;
  P2SValueT<T> v;
  const T tz = std::min(z, half);
  if (rho2 + (z - tz) * (z - tz) <= r * r) return v;  // inside the capsule
  // g(t) = Φ(‖p − t e_z‖ − r) + Φ(t − l/2) over t in [min(z, l/2), z] (z >= 0 by symmetry);
  // g' is increasing; safeguarded Newton on g'(t) = 0.
  T lo = tz, hi = z, t = tz;
  // The stop rule at double's 1e-16, scaled to T's precision.
  const T rel = T(1e-16) * kPrecisionScale<T>;
  auto dg = [&](T tt, T* d2) {
    const T dz = z - tt, d = std::sqrt(rho2 + dz * dz);
    const auto j = phi_.jet_as(d - r);
    const auto jt = phi_.jet_as(tt - half);
    const T c = -dz / d;
    *d2 = j.d2 * c * c + j.d1 / d * (1 - c * c) + jt.d2;
    return j.d1 * c + jt.d1;
  };
  if (z > half) {
    for (int it = 0; it < 100; ++it) {
      T d2;
      const T g1 = dg(t, &d2);
      if (g1 > 0) hi = t;
      else lo = t;
      if (g1 == 0) break;
      T next = t - g1 / d2;
      if (!(next > lo && next < hi)) next = (lo + hi) / 2;
      if (std::abs(next - t) <= rel * std::max(T(1), std::abs(t))) {
        t = next;
        break;
      }
      t = next;
    }
  }
  const Vec3T<T> q(p.x(), p.y(), sign * (z - t));  // p − t* e_z, in p's half-space
  const T d = q.norm();
  const auto j = phi_.jet_as(d - r);
  const auto jt = phi_.jet_as(t - half);
  v.value = j.value + jt.value;
  if (order < 1) return v;
  const Vec3T<T> n = q / d;
  v.gradient = j.d1 * n;
  if (order < 2) return v;
  // Schur complement: H = f_pp − f_pp e ( eᵀ f_pp e + ψ'' )⁻¹ eᵀ f_pp.
  const Mat3T<T> fpp = j.d2 * n * n.transpose() + (j.d1 / d) * (Mat3T<T>::Identity() - n * n.transpose());
  const Vec3T<T> fe = fpp.col(2);
  const T ftt = fe.z() + jt.d2;
  v.hessian = fpp - fe * fe.transpose() / ftt;
  return v;
}

// Polytopes, boxes, spheres and cylinders are evaluated here only in a wider T (strict_at); weak()
// evaluates them in double in world coordinates (halfspaces_world, round_world).
template <class T>
P2SValueT<T> PointToSet::weak_local(const Vec3T<T>& p, int order) const {
  const T round_weight = round_weight_;
  return std::visit(
      Overloaded{
          [&](const Sphere& s) {
            P2SValueT<T> v;
            add_radial_term<T>(v, phi_, p, s.radius, false, order);
            return scaled(v, round_weight);
          },
          [&](const Cylinder& c) {
            P2SValueT<T> v;
            add_radial_term<T>(v, phi_, Vec3T<T>(p.x(), p.y(), T(0)), c.radius, true, order);
            add_linear_term<T>(v, phi_, 1, p.z() - T(c.height) / 2, Vec3T<T>::UnitZ(), order);
            add_linear_term<T>(v, phi_, 1, -p.z() - T(c.height) / 2, -Vec3T<T>::UnitZ(), order);
            return scaled(v, round_weight);
          },
          [&](const Capsule&) { return scaled(capsule_local(p, order), round_weight); },
          [&](const auto&) {
            // Eq. (5) in the shape frame.
            P2SValueT<T> v;
            for (Eigen::Index i = 0; i < A_local_.rows(); ++i) {
              const Vec3T<T> u = A_local_.row(i).transpose().cast<T>();
              add_linear_term<T>(v, phi_, weights_[i], u.dot(p) - T(b_local_[i]), u, order);
            }
            return v;
          }},
      shape_);
}

// Spheres and cylinders in world coordinates: the same terms as weak_local's, about the centre c
// and the axis e = R e_z, with the weight folded in. This spares the evaluation the rotation of p
// into the shape frame and of the derivatives back (a cylinder's E_S is evaluated about ten times
// a GAP solve).
P2SValue PointToSet::round_world(const Vec3& p, int order) const {
  const double w = round_weight_;
  const Vec3 d = p - pose_.position;
  const auto* cyl = std::get_if<Cylinder>(&shape_);
  const Vec3 e = R_.col(2);
  const double z = cyl ? d.dot(e) : 0.0;
  const Vec3 q = cyl ? Vec3(d - z * e) : d;  // across the axis (cylinder) or from the centre
  const double r = cyl ? cyl->radius : std::get<Sphere>(shape_).radius;
  P2SValue v;
  if (const double n2 = q.squaredNorm(); n2 > r * r) {
    const double norm = std::sqrt(n2), inv = 1.0 / norm;
    const auto j = phi_.jet(norm - r);
    v.value = w * j.value;
    if (order >= 1) {
      const Vec3 n = inv * q;
      v.gradient = (w * j.d1) * n;
      if (order >= 2) {
        // Φ'' nnᵀ + Φ'/‖q‖ (P − nnᵀ), P the projector onto q's space: I, or I − eeᵀ.
        const double tangential = w * j.d1 * inv;
        v.hessian.noalias() = (w * j.d2 - tangential) * n * n.transpose();
        v.hessian.diagonal().array() += tangential;
        if (cyl) v.hessian.noalias() -= tangential * e * e.transpose();
      }
    }
  }
  // The cylinder's caps Φ(±z − l/2): with l > 0, at most one is violated.
  if (const double s = cyl ? std::abs(z) - cyl->height / 2 : 0.0; s > 0) {
    const auto j = phi_.jet(s);
    v.value += w * j.value;
    if (order >= 1) v.gradient += (z > 0 ? w * j.d1 : -w * j.d1) * e;
    if (order >= 2) v.hessian.noalias() += (w * j.d2) * e * e.transpose();
  }
  return v;
}

P2SValue PointToSet::weak(const Vec3& p, int order) const {
  if (A_world_.rows() > 0)
    return order >= 2 ? halfspaces_world<2>(p) : order == 1 ? halfspaces_world<1>(p)
                                                            : halfspaces_world<0>(p);
  if (std::holds_alternative<Sphere>(shape_) || std::holds_alternative<Cylinder>(shape_))
    return round_world(p, order);
  P2SValue v = weak_local<double>(pose_.to_local(p), order);
  if (order >= 1) v.gradient = R_ * v.gradient;
  if (order >= 2) v.hessian = R_ * v.hessian * R_.transpose();
  return v;
}

P2SValue PointToSet::strict(const Vec3& p, int order) const {
  return strict_from_weak(weak(p, order), p, strict_, rho_, rho_center_world_, order);
}

template <class T>
P2SValueT<T> PointToSet::strict_at(const Vec3T<T>& p, const PoseT<T>& pose, int order) const {
  const Mat3T<T> R = pose.rotation.normalized().toRotationMatrix();
  P2SValueT<T> e = weak_local<T>(R.transpose() * (p - pose.position), order);
  if (order >= 1) e.gradient = R * e.gradient;
  if (order >= 2) e.hessian = R * e.hessian * R.transpose();
  return strict_from_weak<T>(e, p, strict_, rho_, pose.position + R * rho_.center.cast<T>(), order);
}

template P2SValueT<long double> PointToSet::strict_at(const Vec3T<long double>&, const PoseT<long double>&, int) const;

}  // namespace distlab
