// SPDX-License-Identifier: MIT
#include "modrt/precompute/interfaces.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <stdexcept>
#include <string>
#include <vector>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <Eigen/Eigenvalues>
#include <Eigen/SparseCore>
#include <glm/geometric.hpp>
#include "modrt/precompute/svd.h"

#include "modrt/precompute/block_scene.h"
#include "modrt/precompute/reduction.h"
#include "modrt/precompute/sampling.h"
#include "modrt/precompute/sh_operators.h"
#include "modrt/precompute/symmetry.h"
#include "modrt/sh.h"

namespace modrt::precompute {
namespace {

struct Grid {
  int S, D, ss;
  explicit Grid(const InterfaceSettings& s) : S(s.spatial), D(s.directional), ss(s.supersample) {}
  int size() const { return S * S * D * D; }
  int index(int px, int py, int dx, int dy) const { return ((py * S + px) * D + dy) * D + dx; }
};

struct Taps {
  int count = 0;
  int index[4];
  double weight[4];
};

// Taps of the lightfield sample(s) for light crossing `frame`'s face at q travelling along
// T: bilinear in position (clamped at the face edges), nearest direction bin.
Taps lookup(const Grid& g, const LightfieldFrame& frame, const glm::dvec3& q, const glm::dvec3& T) {
  Taps taps;
  const double tz = glm::dot(T, frame.out);
  if (tz <= 0.0) return taps;
  const glm::dvec2 sq = concentric_disk_to_square({glm::dot(T, frame.u_axis), glm::dot(T, frame.v_axis)});
  const int dx = std::clamp(int(sq.x * g.D), 0, g.D - 1);
  const int dy = std::clamp(int(sq.y * g.D), 0, g.D - 1);
  const glm::dvec3 rel = q - frame.origin;
  const double x = glm::dot(rel, frame.u_axis) * g.S - 0.5;
  const double y = glm::dot(rel, frame.v_axis) * g.S - 0.5;
  const int x0 = int(std::floor(x)), y0 = int(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  for (int b = 0; b < 2; ++b)
    for (int a = 0; a < 2; ++a) {
      const double w = (a ? ax : 1 - ax) * (b ? ay : 1 - ay);
      if (w <= 0.0) continue;
      const int px = std::clamp(x0 + a, 0, g.S - 1), py = std::clamp(y0 + b, 0, g.S - 1);
      taps.index[taps.count] = g.index(px, py, dx, dy);
      taps.weight[taps.count] = w;
      ++taps.count;
    }
  return taps;
}

glm::dvec3 travel_direction(const LightfieldFrame& f, double a, double b) {
  const glm::dvec2 d = concentric_square_to_disk({a, b});
  const double z = std::sqrt(std::max(0.0, 1.0 - d.x * d.x - d.y * d.y));
  return d.x * f.u_axis + d.y * f.v_axis + z * f.out;
}

glm::dvec3 frame_point(const LightfieldFrame& f, double u, double v) {
  return f.origin + u * f.u_axis + v * f.v_axis;
}

// A^T B for tall A, B (same rows), summed over row chunks in parallel: Eigen's own
// products are single-threaded without OpenMP, and these are the bake's largest products.
// The deterministic reduce splits the chunks the same way every run and on any thread
// count, so the sum (and the dictionary) is bit-identical run to run.
MatrixXd parallel_at_b(const MatrixXd& A, const MatrixXd& B) {
  constexpr Eigen::Index kChunk = 2048;
  const Eigen::Index chunks = (A.rows() + kChunk - 1) / kChunk;
  return tbb::parallel_deterministic_reduce(
      tbb::blocked_range<Eigen::Index>(0, chunks), MatrixXd(MatrixXd::Zero(A.cols(), B.cols())),
      [&](const tbb::blocked_range<Eigen::Index>& r, MatrixXd acc) {
        for (Eigen::Index c = r.begin(); c != r.end(); ++c) {
          const Eigen::Index begin = c * kChunk, rows = std::min(kChunk, A.rows() - begin);
          acc.noalias() += A.middleRows(begin, rows).transpose() * B.middleRows(begin, rows);
        }
        return acc;
      },
      [](const MatrixXd& a, const MatrixXd& b) -> MatrixXd { return a + b; });
}

// A B for tall A, row chunks in parallel.
MatrixXd parallel_a_b(const MatrixXd& A, const MatrixXd& B) {
  MatrixXd out(A.rows(), B.cols());
  tbb::parallel_for(tbb::blocked_range<Eigen::Index>(0, A.rows(), 2048),
                    [&](const tbb::blocked_range<Eigen::Index>& r) {
                      out.middleRows(r.begin(), r.size()).noalias() = A.middleRows(r.begin(), r.size()) * B;
                    });
  return out;
}

// Left singular vectors scaled by singular values (U~ S~) of a tall matrix, via the
// eigen-decomposition of A^T A (method of snapshots: O(rows cols^2), much cheaper than a
// full SVD of an 82944-row matrix). Modes below 1e-12 of the largest are dropped.
MatrixXd tall_scaled_basis(const MatrixXd& A, int k, VectorXd* sigma_out = nullptr) {
  const MatrixXd gram = parallel_at_b(A, A);
  Eigen::SelfAdjointEigenSolver<MatrixXd> eig(gram);
  const VectorXd& lambda = eig.eigenvalues();  // ascending
  const Eigen::Index m = lambda.size();
  VectorXd sigma(m);
  for (Eigen::Index i = 0; i < m; ++i) sigma(i) = std::sqrt(std::max(0.0, lambda(m - 1 - i)));
  if (sigma_out) *sigma_out = sigma;
  const Eigen::Index keep = cluster_safe_rank(sigma, k);
  // U S = A V for the kept modes.
  MatrixXd V(A.cols(), keep);
  for (Eigen::Index i = 0; i < keep; ++i) V.col(i) = eig.eigenvectors().col(m - 1 - i);
  MatrixXd basis = MatrixXd::Zero(A.rows(), k);
  basis.leftCols(keep) = parallel_a_b(A, V);
  return basis;
}

// The mirror of a wall lightfield in its own frame: every reflection that keeps +Y and
// maps a side wall onto a side wall reverses u (positions and directions alike).
MatrixXd mirror_lightfield(const Grid& g, const MatrixXd& in) {
  MatrixXd out(in.rows(), in.cols());
  for (int py = 0; py < g.S; ++py)
    for (int px = 0; px < g.S; ++px)
      for (int dy = 0; dy < g.D; ++dy)
        for (int dx = 0; dx < g.D; ++dx)
          out.row(g.index(g.S - 1 - px, py, g.D - 1 - dx, dy)) = in.row(g.index(px, py, dx, dy));
  return out;
}

MatrixXd unit_frobenius(const MatrixXd& m) {
  const double n = m.norm();
  return n > 0.0 ? MatrixXd(m / n) : m;
}

}  // namespace

MatrixXd project_onto_lightfield_basis(const MatrixXd& Hrlf, const MatrixXd& x) {
  // Hrlf = U S: coefficients S^-2 (U S)^T x.
  VectorXd inv_norm2(Hrlf.cols());
  for (Eigen::Index i = 0; i < inv_norm2.size(); ++i) {
    const double n2 = Hrlf.col(i).squaredNorm();
    inv_norm2(i) = n2 > 0.0 ? 1.0 / n2 : 0.0;
  }
  return inv_norm2.asDiagonal() * parallel_at_b(Hrlf, x);
}

MatrixXd reduced_propagation(const MatrixXd& Hrlf, const SparseRowMatrix& P) {
  // S^-2 Hrlf^T (P Hrlf) by row chunks: P Hrlf (s x krlf, 85 MB at the default settings) is
  // never formed, and the chunks run in parallel with a deterministic sum.
  constexpr Eigen::Index kChunk = 2048;
  const Eigen::Index chunks = (P.rows() + kChunk - 1) / kChunk;
  const MatrixXd HtPH = tbb::parallel_deterministic_reduce(
      tbb::blocked_range<Eigen::Index>(0, chunks), MatrixXd(MatrixXd::Zero(Hrlf.cols(), Hrlf.cols())),
      [&](const tbb::blocked_range<Eigen::Index>& r, MatrixXd acc) {
        std::vector<Eigen::Index> live;
        for (Eigen::Index c = r.begin(); c != r.end(); ++c) {
          const Eigen::Index begin = c * kChunk, rows = std::min(kChunk, P.rows() - begin);
          // Only the rows P reaches (bins whose light comes through the entry; in a long box
          // most come from its walls): Hrlf^T P Hrlf sums over them alone.
          live.clear();
          for (Eigen::Index i = begin; i < begin + rows; ++i)
            if (P.outerIndexPtr()[i + 1] > P.outerIndexPtr()[i]) live.push_back(i);
          if (live.empty()) continue;
          MatrixXd PH(Eigen::Index(live.size()), Hrlf.cols()), H(Eigen::Index(live.size()), Hrlf.cols());
          for (std::size_t k = 0; k < live.size(); ++k) {
            PH.row(Eigen::Index(k)) = P.row(live[k]) * Hrlf;
            H.row(Eigen::Index(k)) = Hrlf.row(live[k]);
          }
          acc.noalias() += H.transpose() * PH;
        }
        return acc;
      },
      [](const MatrixXd& a, const MatrixXd& b) -> MatrixXd { return a + b; });
  VectorXd inv_norm2(Hrlf.cols());
  for (Eigen::Index i = 0; i < inv_norm2.size(); ++i) {
    const double n2 = Hrlf.col(i).squaredNorm();
    inv_norm2(i) = n2 > 0.0 ? 1.0 / n2 : 0.0;
  }
  return inv_norm2.asDiagonal() * HtPH;
}

LightfieldFrame exit_frame(int face) {
  const FaceFrame& f = face_frame(face);
  return {f.origin, f.u_axis, f.v_axis, -f.normal};
}

LightfieldFrame entry_frame(int face) {
  // The neighbour across `face` sits one cell along -normal; its opposite face (face ^ 1)
  // is this face's plane, and light leaving it travels along this face's inward normal.
  const FaceFrame& here = face_frame(face);
  const FaceFrame& opposite = face_frame(face ^ 1);
  return {opposite.origin - here.normal, opposite.u_axis, opposite.v_axis, here.normal};
}

int propagation_exit_face(Propagation p) {
  switch (p) {
    case Propagation::straight: return kFacePosZ;
    case Propagation::left: return kFacePosX;
    case Propagation::right: return kFaceNegX;
  }
  return -1;
}

int turns_to_face(int face) {
  for (int t = 0; t < 4; ++t)
    if (rotate_face(kCanonicalEntryFace, t) == face) return t;
  return -1;
}

bool classify_propagation(int entry, int exit, Propagation& out) {
  const int t = turns_to_face(entry);
  if (t < 0 || turns_to_face(exit) < 0 || entry == exit) return false;
  const int canonical_exit = rotate_face(exit, -t);
  for (Propagation p : {Propagation::straight, Propagation::left, Propagation::right})
    if (propagation_exit_face(p) == canonical_exit) {
      out = p;
      return true;
    }
  return false;
}

MatrixXd exit_lightfield(FaceMask shape_mask, int face, const MatrixXd& Limp, int res,
                         const InterfaceSettings& s, const glm::dvec3& extent) {
  const Grid g(s);
  const SampleLayout layout = SampleLayout::make(shape_mask, res);
  const BlockScene scene(shape_mask, extent);
  const LightfieldFrame frame = exit_frame(face);
  MatrixXd out = MatrixXd::Zero(g.size(), Limp.cols());
  const double w = 1.0 / (g.ss * g.ss);
  tbb::parallel_for(tbb::blocked_range<int>(0, g.S * g.S), [&](const tbb::blocked_range<int>& range) {
    Eigen::RowVectorXd acc(Limp.cols());
    for (int pos = range.begin(); pos != range.end(); ++pos) {
      const int px = pos % g.S, py = pos / g.S;
      const glm::dvec3 p = scene.point(frame_point(frame, (px + 0.5) / g.S, (py + 0.5) / g.S));
      for (int dy = 0; dy < g.D; ++dy)
        for (int dx = 0; dx < g.D; ++dx) {
          acc.setZero();
          for (int sy = 0; sy < g.ss; ++sy)
            for (int sx = 0; sx < g.ss; ++sx) {
              const glm::dvec3 T =
                  travel_direction(frame, (dx + (sx + 0.5) / g.ss) / g.D, (dy + (sy + 0.5) / g.ss) / g.D);
              // The radiance travelling along T through p left a surface inside the block.
              const FaceHit hit = scene.intersect(p, -T);
              if (hit.face < 0) continue;
              const BilinearTaps taps = bilinear_taps(hit.u, hit.v, res);
              for (int t = 0; t < 4; ++t)
                acc += taps.w[t] * Limp.row(layout.index(hit.face, taps.i[t], taps.j[t]));
            }
          out.row(g.index(px, py, dx, dy)) = w * acc;
        }
    }
  });
  return out;
}

SparseRowMatrix propagation_operator(Propagation dir, const InterfaceSettings& s) {
  return box_propagation_operator(glm::dvec3(1.0), kCanonicalEntryFace, propagation_exit_face(dir), s);
}

SparseRowMatrix box_propagation_operator(const glm::dvec3& extent, int entry, int exit,
                                         const InterfaceSettings& s) {
  const Grid g(s);
  const LightfieldFrame out_frame = exit_frame(exit);
  const LightfieldFrame in_frame = entry_frame(entry);
  const FaceFrame& entry_face = face_frame(entry);
  const double w = 1.0 / (g.ss * g.ss);
  // Rows are independent: build each position's rows in parallel, then assemble.
  std::vector<std::vector<Eigen::Triplet<double>>> rows(std::size_t(g.S * g.S));
  tbb::parallel_for(tbb::blocked_range<int>(0, g.S * g.S), [&](const tbb::blocked_range<int>& range) {
    std::vector<std::pair<int, double>> taps_of_row;
    for (int pos = range.begin(); pos != range.end(); ++pos) {
      const int px = pos % g.S, py = pos / g.S;
      const glm::dvec3 p = extent * frame_point(out_frame, (px + 0.5) / g.S, (py + 0.5) / g.S);
      std::vector<Eigen::Triplet<double>>& triplets = rows[std::size_t(pos)];
      for (int dy = 0; dy < g.D; ++dy)
        for (int dx = 0; dx < g.D; ++dx) {
          taps_of_row.clear();
          for (int sy = 0; sy < g.ss; ++sy)
            for (int sx = 0; sx < g.ss; ++sx) {
              const glm::dvec3 T =
                  travel_direction(out_frame, (dx + (sx + 0.5) / g.ss) / g.D, (dy + (sy + 0.5) / g.ss) / g.D);
              // Walk back along -T to the entry plane; inside a convex cell the segment
              // between two faces meets no wall, so this is exact free-space transport.
              // The walk is in the box's coordinates, the lookup in the canonical cell's
              // (lightfield positions are normalised to the face).
              const double along = glm::dot(T, entry_face.normal);
              if (along <= 1e-12) continue;
              const double dist = glm::dot(p - extent * entry_face.origin, entry_face.normal) / along;
              const glm::dvec3 q = (p - dist * T) / extent;
              const glm::dvec3 rel = q - entry_face.origin;
              const double u = glm::dot(rel, entry_face.u_axis), v = glm::dot(rel, entry_face.v_axis);
              if (u < 0.0 || u > 1.0 || v < 0.0 || v > 1.0) continue;  // came from another face
              const Taps taps = lookup(g, in_frame, q, T);
              for (int t = 0; t < taps.count; ++t)
                taps_of_row.emplace_back(taps.index[t], w * taps.weight[t]);
            }
          std::sort(taps_of_row.begin(), taps_of_row.end());
          const int row = g.index(px, py, dx, dy);
          for (std::size_t i = 0; i < taps_of_row.size();) {
            double sum = 0.0;
            std::size_t j = i;
            for (; j < taps_of_row.size() && taps_of_row[j].first == taps_of_row[i].first; ++j)
              sum += taps_of_row[j].second;
            triplets.emplace_back(row, taps_of_row[i].first, sum);
            i = j;
          }
        }
    }
  });
  std::vector<Eigen::Triplet<double>> all;
  for (const auto& r : rows) all.insert(all.end(), r.begin(), r.end());
  SparseRowMatrix P(g.size(), g.size());
  P.setFromTriplets(all.begin(), all.end());
  return P;
}

MatrixXd propagate_lightfield(const MatrixXd& in, Propagation dir, const InterfaceSettings& s) {
  return propagation_operator(dir, s) * in;
}

MatrixXd response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s,
                                const glm::dvec3& extent) {
  const Grid g(s);
  const FaceMask receiver = dictionary_shape_mask(1);  // dead end: only -Z missing
  const SampleLayout layout = SampleLayout::make(receiver, res);
  const BlockScene scene(receiver, extent);
  const LightfieldFrame in_frame = entry_frame(kCanonicalEntryFace);
  const FaceFrame& entry_face = face_frame(kCanonicalEntryFace);
  const int n = layout.sample_count();
  MatrixXd out = MatrixXd::Zero(n, in.cols());
  const double w = 1.0 / s.response_rays;
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4), [&](const tbb::blocked_range<int>& range) {
    std::vector<glm::dvec2> strata;
    Eigen::RowVectorXd acc(in.cols());
    for (int smp = range.begin(); smp != range.end(); ++smp) {
      Rng rng(s.seed, std::uint64_t(smp));
      stratified_square(s.response_rays, rng, strata);
      const FaceFrame& frame = face_frame(layout.face_of(smp));
      const glm::dvec3 x = scene.point(layout.position(smp));
      acc.setZero();
      for (const glm::dvec2& u : strata) {
        const glm::dvec3 d = to_world(cosine_hemisphere(u), frame.u_axis, frame.v_axis, frame.normal);
        if (scene.intersect(x, d).face >= 0) continue;  // sees this block's own surface
        const double along = -glm::dot(d, entry_face.normal);
        if (along <= 1e-12) continue;
        // The entry plane z = 0 is the same in the box's and the canonical coordinates.
        const glm::dvec3 q = x + (glm::dot(x - entry_face.origin, entry_face.normal) / along) * d;
        const Taps taps = lookup(g, in_frame, q / extent, -d);
        for (int t = 0; t < taps.count; ++t) acc += taps.weight[t] * in.row(taps.index[t]);
      }
      out.row(smp) = w * acc;
    }
  });
  return out;
}

MatrixXd symmetric_response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s,
                                          const glm::dvec3& extent) {
  const MatrixXd G = response_to_lightfield(in, res, s, extent);
  const MatrixXd G_mirrored = response_to_lightfield(mirror_lightfield(Grid(s), in), res, s, extent);
  const SampleLayout dead_end = SampleLayout::make(dictionary_shape_mask(1), res);
  const std::vector<int> perm = sample_permutation(dead_end, BlockSymmetry{true, 0});
  MatrixXd out(G.rows(), G.cols());
  for (Eigen::Index r = 0; r < G.rows(); ++r)
    out.row(r) = 0.5 * (G.row(r) + G_mirrored.row(perm[std::size_t(r)]));
  return out;
}

MatrixXd vector_response_to_lightfield(const MatrixXd& in, int res, const InterfaceSettings& s) {
  const Grid g(s);
  const FaceMask receiver = dictionary_shape_mask(1);  // dead end: only -Z missing
  const SampleLayout layout = SampleLayout::make(receiver, res);
  const BlockScene scene(receiver);
  const LightfieldFrame in_frame = entry_frame(kCanonicalEntryFace);
  const FaceFrame& entry_face = face_frame(kCanonicalEntryFace);
  const int n = layout.sample_count();
  MatrixXd out = MatrixXd::Zero(4 * Eigen::Index(n), in.cols());
  tbb::parallel_for(tbb::blocked_range<int>(0, n, 4), [&](const tbb::blocked_range<int>& range) {
    std::vector<glm::dvec2> strata;
    Eigen::Matrix<double, 9, Eigen::Dynamic> acc(9, in.cols());
    Eigen::RowVectorXd radiance(in.cols());
    for (int smp = range.begin(); smp != range.end(); ++smp) {
      Rng rng(s.seed ^ 0x7ec7ull, std::uint64_t(smp));
      stratified_square(s.response_rays, rng, strata);
      const FaceFrame& frame = face_frame(layout.face_of(smp));
      const glm::dvec3 x = layout.position(smp);
      acc.setZero();
      for (const glm::dvec2& u : strata) {
        // Uniform over the hemisphere (the SH projection needs radiance, not E).
        const glm::dvec3 local = uniform_hemisphere(u);
        const glm::dvec3 d = to_world(local, frame.u_axis, frame.v_axis, frame.normal);
        if (scene.intersect(x, d).face >= 0) continue;
        const double along = -glm::dot(d, entry_face.normal);
        if (along <= 1e-12) continue;
        const glm::dvec3 q = x + (glm::dot(x - entry_face.origin, entry_face.normal) / along) * d;
        const Taps taps = lookup(g, in_frame, q, -d);
        radiance.setZero();
        for (int t = 0; t < taps.count; ++t) radiance += taps.weight[t] * in.row(taps.index[t]);
        double y[9];
        sh9_eval(local, y);
        acc.noalias() += Eigen::Map<const Eigen::Matrix<double, 9, 1>>(y) * radiance;
      }
      acc *= 2.0 * std::numbers::pi / s.response_rays;  // pdf 1 / (2 pi)
      for (Eigen::Index k = 0; k < in.cols(); ++k) {
        double L[kSh9Count], E[kSh9Count], a[kOhlshCount];
        for (int j = 0; j < kSh9Count; ++j) L[j] = acc(j, k);
        irradiance_from_radiance_sh9(L, E);
        ohlsh_from_sh9(E, a);
        for (int i = 0; i < kOhlshCount; ++i) out(4 * Eigen::Index(smp) + i, k) = a[i];
      }
    }
  });
  return out;
}

MatrixXd probe_response_to_lightfield(const MatrixXd& in, const InterfaceSettings& s) {
  const Grid g(s);
  const BlockScene scene(dictionary_shape_mask(1));
  const LightfieldFrame in_frame = entry_frame(kCanonicalEntryFace);
  const FaceFrame& entry_face = face_frame(kCanonicalEntryFace);
  const int probes = s.probe_grid * s.probe_grid * s.probe_grid;
  MatrixXd out = MatrixXd::Zero(9 * Eigen::Index(probes), in.cols());
  tbb::parallel_for(tbb::blocked_range<int>(0, probes), [&](const tbb::blocked_range<int>& range) {
    std::vector<glm::dvec2> strata;
    Eigen::Matrix<double, 9, Eigen::Dynamic> acc(9, in.cols());
    Eigen::RowVectorXd radiance(in.cols());
    for (int p = range.begin(); p != range.end(); ++p) {
      Rng rng(s.seed ^ 0x9e37ull, std::uint64_t(p));
      stratified_square(s.probe_rays, rng, strata);
      const glm::dvec3 x = probe_position(p, s.probe_grid);
      acc.setZero();
      for (const glm::dvec2& u : strata) {
        const glm::dvec3 d = uniform_sphere(u);
        if (scene.intersect(x, d).face >= 0) continue;
        const double along = -glm::dot(d, entry_face.normal);
        if (along <= 1e-12) continue;
        const glm::dvec3 q = x + (glm::dot(x - entry_face.origin, entry_face.normal) / along) * d;
        const Taps taps = lookup(g, in_frame, q, -d);
        radiance.setZero();
        for (int t = 0; t < taps.count; ++t) radiance += taps.weight[t] * in.row(taps.index[t]);
        double y[9];
        sh9_eval(d, y);
        acc.noalias() += Eigen::Map<const Eigen::Matrix<double, 9, 1>>(y) * radiance;
      }
      out.middleRows(9 * Eigen::Index(p), 9) = acc * (4.0 * std::numbers::pi / s.probe_rays);
    }
  });
  return out;
}

Status validate_interface_settings(const InterfaceSettings& s) {
  const struct {
    const char* name;
    int value, lo;
    std::uint32_t hi;
  } counts[] = {{"spatial", s.spatial, 1, kMaxSettingsLightfieldSpatial},
                {"directional", s.directional, 1, kMaxSettingsLightfieldDirectional},
                {"supersample", s.supersample, 1, kMaxSettingsLightfieldSupersample},
                {"krlf", s.krlf, 1, kMaxSettingsModes},
                {"kr", s.kr, 1, kMaxSettingsModes},
                {"enrichment_iterations", s.enrichment_iterations, 0, kMaxSettingsEnrichment},
                {"response_rays", s.response_rays, 1, kMaxSettingsRays},
                {"probe_grid", s.probe_grid, 1, kMaxSettingsProbeGrid},
                {"probe_rays", s.probe_rays, 1, kMaxSettingsRays}};
  for (const auto& c : counts)
    if (c.value < c.lo || std::int64_t(c.value) > std::int64_t(c.hi))
      return Status::error(ErrorCode::invalid_argument,
                           std::string("interface settings: ") + c.name + " = " + std::to_string(c.value) +
                               ": must be in [" + std::to_string(c.lo) + ", " + std::to_string(c.hi) + "]");
  return Status::success();
}

InterfaceBake bake_interfaces(const ShapeLimps& limps, int res, const InterfaceSettings& settings,
                              const std::function<void(const std::string&, double)>& on_stage) {
  if (Status s = validate_interface_settings(settings); !s.ok()) throw std::invalid_argument(s.message());
  if (res < 1 || res > int(kMaxSettingsRes))
    throw std::invalid_argument("interface settings: res = " + std::to_string(res) + ": must be in [1, " +
                                std::to_string(kMaxSettingsRes) + "]");
  auto start = std::chrono::steady_clock::now();
  auto stage = [&](const char* name) {
    const auto now = std::chrono::steady_clock::now();
    if (on_stage) on_stage(name, std::chrono::duration<double>(now - start).count());
    start = now;
  };
  InterfaceBake bake;
  bake.settings = settings;

  // Raw lightfields of every implicit light of every shape through every interface.
  struct Block {
    int shape, face;
    Eigen::Index first_col, cols;
  };
  std::vector<Block> blocks;
  Eigen::Index total_cols = 0;
  for (int shape = 0; shape < kDictionaryShapeCount; ++shape)
    for (int face = 0; face < kFaceCount; ++face)
      if (!face_present(dictionary_shape_mask(shape), face)) {
        blocks.push_back({shape, face, total_cols, limps[std::size_t(shape)]->cols()});
        total_cols += limps[std::size_t(shape)]->cols();
      }
  const Grid g(settings);
  MatrixXd Hlf(g.size(), total_cols);
  for (const Block& b : blocks)
    Hlf.middleCols(b.first_col, b.cols) =
        exit_lightfield(dictionary_shape_mask(b.shape), b.face, *limps[std::size_t(b.shape)], res, settings);
  stage("lightfields");

  // Hrlf and its enrichment with propagated outputs (appendix A).
  const std::array<SparseRowMatrix, 3> P = {propagation_operator(Propagation::straight, settings),
                                            propagation_operator(Propagation::left, settings),
                                            propagation_operator(Propagation::right, settings)};
  stage("propagation operators");
  // The raw lightfields and their mirror images: the reduced basis must be closed under
  // mirroring for a level and its mirror image to light identically.
  {
    MatrixXd with_mirror(Hlf.rows(), 2 * Hlf.cols());
    with_mirror << Hlf, mirror_lightfield(g, Hlf);
    bake.Hrlf = tall_scaled_basis(with_mirror, settings.krlf, &bake.sigma_lf);
  }
  for (int it = 0; it < settings.enrichment_iterations; ++it) {
    MatrixXd all(Hlf.rows(), 4 * bake.Hrlf.cols());
    all.leftCols(bake.Hrlf.cols()) = unit_frobenius(bake.Hrlf);
    MatrixXd propagated(Hlf.rows(), 3 * bake.Hrlf.cols());
    for (int d = 0; d < 3; ++d)
      propagated.middleCols(d * bake.Hrlf.cols(), bake.Hrlf.cols()) = P[std::size_t(d)] * bake.Hrlf;
    all.rightCols(3 * bake.Hrlf.cols()) = unit_frobenius(propagated);
    bake.Hrlf = tall_scaled_basis(all, settings.krlf);
  }
  stage("Hrlf + enrichment");

  auto project = [&](const MatrixXd& x) -> MatrixXd { return project_onto_lightfield_basis(bake.Hrlf, x); };
  for (int d = 0; d < 3; ++d) bake.R[std::size_t(d)] = project(P[std::size_t(d)] * bake.Hrlf);
  const MatrixXd coefficients = project(Hlf);
  for (const Block& b : blocks)
    bake.Rb_rlf[std::size_t(b.shape)][std::size_t(b.face)] =
        coefficients.middleRows(0, coefficients.rows()).middleCols(b.first_col, b.cols);
  stage("R operators");

  bake.G = symmetric_response_to_lightfield(bake.Hrlf, res, settings);
  Eigen::BDCSVD<MatrixXd> svd(bake.G, Eigen::ComputeThinU | Eigen::ComputeThinV);
  bake.sigma_G = svd.singularValues();
  const Eigen::Index kr = std::min<Eigen::Index>(settings.kr, bake.sigma_G.size());
  bake.Ur = MatrixXd::Zero(bake.G.rows(), settings.kr);
  bake.Trlf_r = MatrixXd::Zero(settings.kr, bake.G.cols());
  bake.Ur.leftCols(kr) = svd.matrixU().leftCols(kr);
  bake.Trlf_r.topRows(kr) = bake.sigma_G.head(kr).asDiagonal() * svd.matrixV().leftCols(kr).transpose();
  // Probes: r = Sg~ Vg~^T c, so the probe response to c restricted to span(Vg~) is
  // Gvol Vg~ Sg~^-1 r (MRT §6.5 "likewise for interface response").
  const MatrixXd Gvol = probe_response_to_lightfield(bake.Hrlf, settings);
  bake.Urvol = MatrixXd::Zero(Gvol.rows(), settings.kr);
  for (Eigen::Index i = 0; i < kr; ++i)
    if (bake.sigma_G(i) > 1e-12 * bake.sigma_G(0))
      bake.Urvol.col(i) = Gvol * svd.matrixV().col(i) / bake.sigma_G(i);
  // Vector irradiance (MRT §6.4) of the same response, restricted to span(Vg~) like Urvol.
  const MatrixXd Gvec = vector_response_to_lightfield(bake.Hrlf, res, settings);
  bake.Ur_vec = MatrixXd::Zero(Gvec.rows(), settings.kr);
  for (Eigen::Index i = 0; i < kr; ++i)
    if (bake.sigma_G(i) > 1e-12 * bake.sigma_G(0))
      bake.Ur_vec.col(i) = Gvec * svd.matrixV().col(i) / bake.sigma_G(i);
  stage("response G, Ur, Trlf_r, Urvol, Ur_vec");
  return bake;
}

}  // namespace modrt::precompute
