// Particle-particle contact forces of the built-in DEM over the half neighbour list
// (docs/builtin-dem.md, "Performance design"). Rows are taken in batches: a first pass finds the
// touching slots of the batch, then loops over the batch's contacts compute their distances, their
// cohesive forces and the contact law, each loop vectorised across contacts (compiled for AVX-512,
// AVX2 and the baseline, the widest the CPU has chosen at run time), and a last pass adds the forces to
// the particles and stores the histories. The results are those of one contact after the other,
// bit for bit: the same operations in the same order on each contact, no fused multiply-add.
#include "demfem/backends/builtin/simulation.hpp"

#include "contact_kinematics.hpp"
#include "vectorised_loop.hpp"
#include "demfem/backends/physics/dem_assert.hpp"

#include <algorithm>
#include <atomic>
#include <cmath>

namespace demfem::builtin {

using detail::norm2;

namespace {

constexpr std::size_t kBatchContacts = 256;  // touching contacts per batch (rows are not split)

// What the loops over a batch read: the simulation's particle arrays, the pair laws, the list
// slots' stiffness, and the batch's contacts (slot, i, j, law index; centre difference x_i - x_j,
// distance, inverse).
struct PairInputs {
  const double *v, *w, *radius, *inv_inertia;
  const PairLaw* laws;
  const ContactStiffness* stiffness;
  const std::int32_t *slot, *i, *j, *law;
  const double *d0, *d1, *d2, *r, *rinv, *cohesion;
};

// r = |d|, rinv = 1 / r for count contacts (d = x_i - x_j by component).
[[gnu::always_inline]] inline void distances(const double* d0, const double* d1, const double* d2, std::size_t count,
                                             double* r, double* rinv) {
  DEMFEM_INDEPENDENT_ITERATIONS
  for (std::size_t k = 0; k < count; ++k) {
    r[k] = std::sqrt(d0[k] * d0[k] + d1[k] * d1[k] + d2[k] * d2[k]);  // norm2's order
    rinv[k] = 1.0 / r[k];
  }
}

// The cohesive normal force of count contacts (cohesionForce<C>).
template <study::CohesionModel C>
[[gnu::always_inline]] inline void pairCohesion(const PairInputs& in, std::size_t count, double* cohesion) {
  const PairInputs p = in;  // the arrays in registers: the stores below do not reach them
  DEMFEM_INDEPENDENT_ITERATIONS
  for (std::size_t k = 0; k < count; ++k) {
    const double ri = p.radius[p.i[k]], rj = p.radius[p.j[k]];
    const PairOverlap o = pairOverlap(p.r[k], ri, rj);
    cohesion[k] = cohesionForce<C>(p.laws[p.law[k]].cohesion_J_m3, o.reff, o.delta, ri, p.r[k], rj, false);
  }
}

// The law of count contacts into the batch's result arrays.
template <study::NormalModel N, study::RollingModel R, bool Shear>
[[gnu::always_inline]] inline void pairLaws(const study::ContactModel& model, const PairInputs& inputs, std::size_t count,
                                            double dt, double rolling_dt, PairBatch& out) {
  constexpr HistoryLayout L = HistoryLayout::of(N, R, Shear);
  const PairInputs in = inputs;  // the arrays in registers: the stores below do not reach them
  const study::ContactModel m = model;
  double *f0 = out.f[0].data(), *f1 = out.f[1].data(), *f2 = out.f[2].data();
  double *ti0 = out.ti[0].data(), *ti1 = out.ti[1].data(), *ti2 = out.ti[2].data();
  double *tj0 = out.tj[0].data(), *tj1 = out.tj[1].data(), *tj2 = out.tj[2].data();
  double* delta = out.delta.data();
  // The history in the batch's arrays, one per stored offset (filled by the caller, updated here):
  // contiguous loads, where reading it from the list slots would be a gather of the slot's stride.
  double* const hist[HistoryLayout::kMaxSize] = {out.hist[0].data(), out.hist[1].data(), out.hist[2].data(), out.hist[3].data(),
                                                 out.hist[4].data(), out.hist[5].data(), out.hist[6].data()};
  DEMFEM_INDEPENDENT_ITERATIONS
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = static_cast<std::size_t>(in.i[k]), j = static_cast<std::size_t>(in.j[k]);
    const std::size_t s = static_cast<std::size_t>(in.slot[k]);
    const double rinv = in.rinv[k];
    const double normal[3] = {in.d0[k] * rinv, in.d1[k] * rinv, in.d2[k] * rinv};
    ContactKinematics kin = contactKinematics<false>(normal, in.r[k], in.radius[i], in.radius[j], &in.v[3 * i], &in.w[3 * i],
                                                     &in.v[3 * j], &in.w[3 * j]);
    kin.wrel_norm = std::sqrt(norm2(kin.wrel));
    kin.inv_ii = in.inv_inertia[i];
    kin.inv_ij = in.inv_inertia[j];
    ContactHistory h = loadBatchHistory<L>(hist, k);
    const ContactResult res =
        contactForce<N, R, Shear>(m, in.laws[in.law[k]], in.stiffness[s], kin, dt, rolling_dt, in.cohesion[k], h, false);
    f0[k] = res.force[0];
    f1[k] = res.force[1];
    f2[k] = res.force[2];
    ti0[k] = res.torque_i[0];
    ti1[k] = res.torque_i[1];
    ti2[k] = res.torque_i[2];
    tj0[k] = res.torque_j[0];
    tj1[k] = res.torque_j[1];
    tj2[k] = res.torque_j[2];
    delta[k] = kin.delta;
    storeBatchHistory<L>(h, hist, k);
  }
}

std::atomic<VectorIsa> vector_isa_cap{VectorIsa::Avx512};

}  // namespace

VectorIsa hostVectorIsa() {
#if defined(__x86_64__)
  static const VectorIsa isa = __builtin_cpu_supports("avx512f") ? VectorIsa::Avx512
                               : __builtin_cpu_supports("avx2")  ? VectorIsa::Avx2
                                                                 : VectorIsa::Baseline;
  return isa;
#else
  return VectorIsa::Baseline;
#endif
}

VectorIsa vectorIsa() { return std::min(hostVectorIsa(), vector_isa_cap.load(std::memory_order_relaxed)); }

void capVectorIsa(VectorIsa widest) { vector_isa_cap.store(widest, std::memory_order_relaxed); }

const char* vectorIsaName(VectorIsa isa) {
  switch (isa) {
    case VectorIsa::Baseline: return "baseline";
    case VectorIsa::Avx2: return "avx2";
    case VectorIsa::Avx512: return "avx512";
  }
  return "unknown";
}

void PairBatch::growTo(std::size_t slots) {
  if (slot.size() >= slots) return;
  for (auto* a : {&slot, &i, &j, &law}) a->resize(slots);
  for (auto* a : {&r, &rinv, &cohesion, &delta}) a->resize(slots);
  for (auto* a : {d, f, ti, tj})
    for (int c = 0; c < 3; ++c) a[c].resize(slots);
  for (auto& h : hist) h.resize(slots);
}

void DemSimulation::pairForces(int part) {
  withModel(model_, [&]<study::NormalModel N, study::RollingModel R, bool Shear>() { pairLoop<N, R, Shear>(part); });
}

template <study::NormalModel N, study::RollingModel R, bool Shear>
void DemSimulation::pairLoop(int part) {
  const std::size_t n = particleCount();
  constexpr int H = HistoryLayout::of(N, R, Shear).size;
  DEMFEM_ASSERT(H == layout_.size);
  PartState& ts = part_[part];
  PairBatch& b = ts.batch;
  // Part `part` owns rows [lo, hi); it writes particles [lo, window_end) only (half list: j > i).
  // No other part writes f_ and t_ of [lo, hi) in this phase, so the sums of its own particles go
  // there directly; those of the particles past hi go to its buffer, cleared and summed over
  // [hi, window_end) alone (sumPairForces). One part (one thread) has no buffer.
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part), window_end = part_window_end_[part];
  DEMFEM_ASSERT(nb_start_.size() == n + 1 && window_end >= hi && window_end <= n);
  double* const F = f_.data();
  double* const Tq = t_.data();
  double* Fpast = F;
  double* Tpast = Tq;
  if (threads_ > 1) {
    ts.f.resize(3 * n);
    ts.t.resize(3 * n);
    std::fill(ts.f.begin() + 3 * hi, ts.f.begin() + 3 * window_end, 0.0);
    std::fill(ts.t.begin() + 3 * hi, ts.t.begin() + 3 * window_end, 0.0);
    Fpast = ts.f.data();
    Tpast = ts.t.data();
  }
  double local_max = 0;
  std::int64_t bad = -1;
  for (std::size_t i0 = lo; i0 < hi;) {
    // Rows [i0, i1) until the batch holds kBatchContacts slots.
    std::size_t i1 = i0;
    while (i1 < hi && static_cast<std::size_t>(nb_start_[i1] - nb_start_[i0]) < kBatchContacts) ++i1;
    b.growTo(static_cast<std::size_t>(nb_start_[i1] - nb_start_[i0]));
    const std::size_t count = findTouching<H>(i0, i1, window_end, b);
    runVectorised([&]() DEMFEM_INLINE {
      distances(b.d[0].data(), b.d[1].data(), b.d[2].data(), count, b.r.data(), b.rinv.data());
    });
    const PairInputs in{v_.data(),       w_.data(),       radius_.data(),  inv_inertia_.data(), table_.laws.data(),
                        nb_stiff_.data(), b.slot.data(),   b.i.data(),      b.j.data(),          b.law.data(),
                        b.d[0].data(),   b.d[1].data(),   b.d[2].data(),   b.r.data(),          b.rinv.data(),
                        b.cohesion.data()};
    withCohesion(model_.cohesion, [&]<study::CohesionModel C>() {
      runVectorised([&]() DEMFEM_INLINE { pairCohesion<C>(in, count, b.cohesion.data()); });
    });
    const double rolling_dt = rollingStep();
    runVectorised([&]() DEMFEM_INLINE { pairLaws<N, R, Shear>(model_, in, count, dt_, rolling_dt, b); });
    const double batch_max = scatterBatch<H>(i0, i1, count, hi, b, F, Tq, Fpast, Tpast);
    local_max = std::max(local_max, batch_max);
    // The overlap limit, checked contact by contact only where the batch's largest overlap could
    // exceed it (rarely): the first failing row in slot order, as a check of every contact finds.
    if (bad < 0 && batch_max > overlapLimitFraction() * list_min_radius_) bad = firstOverlapFailure(count, b);
    i0 = i1;
  }
  ts.pair_max = local_max;
  ts.pair_bad = bad;
}

// The touching slots of rows [i0, i1) into the batch with their histories, written at the next
// free place whether touching or not and kept by advancing the count (no branch on the contact); a
// slot that stopped touching loses its history. One loop over the slots, each with its row: a loop
// over rows, with their few slots each, mispredicts where every row ends. The arrays are taken as
// local pointers once: a store through one of them cannot then make the compiler reload the others
// every slot.
template <int H>
std::size_t DemSimulation::findTouching(std::size_t i0, std::size_t i1, [[maybe_unused]] std::size_t window_end,
                                       PairBatch& b) {
  const double* const x = x_.data();
  const double* const radius = radius_.data();
  const std::int32_t* const material = material_.data();
  const std::int32_t *const nb_i = nb_i_.data(), *const nb_j = nb_j_.data();
  std::uint8_t* const touch = nb_touch_.data();
  double* const stored_hist = nb_hist_.data();
  std::int32_t *const slot = b.slot.data(), *const bi = b.i.data(), *const bj = b.j.data(), *const law = b.law.data();
  double *const d0 = b.d[0].data(), *const d1 = b.d[1].data(), *const d2 = b.d[2].data();
  double* hist[H > 0 ? H : 1];
  for (int c = 0; c < H; ++c) hist[c] = b.hist[c].data();
  const auto M = static_cast<std::int32_t>(table_.materials.size());
  const std::int32_t end = nb_start_[i1];  // read once: the stores below could alias nb_start_
  std::size_t count = 0;
  for (std::int32_t s = nb_start_[i0]; s < end; ++s) {
    const std::int32_t i = nb_i[s], j = nb_j[s];
    DEMFEM_ASSERT(static_cast<std::size_t>(i) >= i0 && static_cast<std::size_t>(i) < i1 && j > i &&
                  static_cast<std::size_t>(j) < window_end);
    const double *xi = x + 3 * static_cast<std::size_t>(i), *xj = x + 3 * static_cast<std::size_t>(j);
    const double d[3] = {xi[0] - xj[0], xi[1] - xj[1], xi[2] - xj[2]};
    const double rs = radius[i] + radius[j];
    const double r2 = norm2(d);
    const std::uint8_t touching = r2 < rs * rs;
    double* const slot_hist = stored_hist + static_cast<std::size_t>(s) * H;
    if (touching != touch[s]) [[unlikely]] {
      touch[s] = touching;
      if (!touching) std::fill_n(slot_hist, H, 0.0);
    }
    slot[count] = s;
    bi[count] = i;
    bj[count] = j;
    law[count] = material[i] * M + material[j];
    d0[count] = d[0];
    d1[count] = d[1];
    d2[count] = d[2];
    for (int c = 0; c < H; ++c) hist[c][count] = slot_hist[c];
    count += touching;
  }
  return count;
}

// The batch's forces to the particles in slot order (i's sums stay in registers over its row: F
// and Tq for the part's own particles, Fpast and Tpast past its range), the histories back to their
// slots. Returns the batch's largest overlap.
template <int H>
double DemSimulation::scatterBatch(std::size_t i0, std::size_t i1, std::size_t count, std::size_t hi,
                                   const PairBatch& b, double* F, double* Tq, double* Fpast, double* Tpast) {
  const std::int32_t* const start = nb_start_.data();
  double* const stored_hist = nb_hist_.data();
  const std::int32_t *const slot = b.slot.data(), *const bj = b.j.data();
  const double* const delta = b.delta.data();
  const double *const f0 = b.f[0].data(), *const f1 = b.f[1].data(), *const f2 = b.f[2].data();
  const double *const ti0 = b.ti[0].data(), *const ti1 = b.ti[1].data(), *const ti2 = b.ti[2].data();
  const double *const tj0 = b.tj[0].data(), *const tj1 = b.tj[1].data(), *const tj2 = b.tj[2].data();
  const double* hist[H > 0 ? H : 1];
  for (int c = 0; c < H; ++c) hist[c] = b.hist[c].data();
  double batch_max = 0;
  std::size_t k = 0;
  for (std::size_t i = i0; i < i1; ++i) {
    double fi[3] = {0, 0, 0}, ti[3] = {0, 0, 0};
    for (; k < count && slot[k] < start[i + 1]; ++k) {
      const std::size_t j = static_cast<std::size_t>(bj[k]);
      if (delta[k] > batch_max) batch_max = delta[k];
      double* const slot_hist = stored_hist + static_cast<std::size_t>(slot[k]) * H;
      for (int c = 0; c < H; ++c) slot_hist[c] = hist[c][k];
      double* const Fj = (j < hi ? F : Fpast) + 3 * j;
      double* const Tj = (j < hi ? Tq : Tpast) + 3 * j;
      fi[0] += f0[k];
      fi[1] += f1[k];
      fi[2] += f2[k];
      Fj[0] -= f0[k];
      Fj[1] -= f1[k];
      Fj[2] -= f2[k];
      ti[0] += ti0[k];
      ti[1] += ti1[k];
      ti[2] += ti2[k];
      Tj[0] += tj0[k];
      Tj[1] += tj1[k];
      Tj[2] += tj2[k];
    }
    for (int c = 0; c < 3; ++c) {
      F[3 * i + c] += fi[c];
      Tq[3 * i + c] += ti[c];
    }
  }
  return batch_max;
}

// The row of the batch's first contact (slot order) whose overlap exceeds the limit fraction of
// the smaller radius, or -1.
std::int64_t DemSimulation::firstOverlapFailure(std::size_t count, const PairBatch& b) const {
  for (std::size_t k = 0; k < count; ++k)
    if (b.delta[k] > overlapLimitFraction() * std::min(radius_[b.i[k]], radius_[b.j[k]])) return b.i[k];
  return -1;
}

// With more than one part: each particle of this part's range adds the buffers of the earlier
// parts whose window reaches it, in part order (its own part's sums are in f_ and t_ already).
void DemSimulation::sumPairForces(int part) {
  if (threads_ == 1) return;
  const std::size_t lo = rangeBegin(part);
  std::size_t reach = lo;  // past it no earlier part's window
  for (int t = 0; t < part; ++t) reach = std::max(reach, part_window_end_[t]);
  for (std::size_t i = lo; i < std::min(reach, rangeEnd(part)); ++i) {
    double fs[3] = {f_[3 * i], f_[3 * i + 1], f_[3 * i + 2]};
    double tsum[3] = {t_[3 * i], t_[3 * i + 1], t_[3 * i + 2]};
    for (int t = 0; t < part; ++t) {
      if (i >= part_window_end_[t]) continue;
      for (int c = 0; c < 3; ++c) {
        fs[c] += part_[t].f[3 * i + c];
        tsum[c] += part_[t].t[3 * i + c];
      }
    }
    for (int c = 0; c < 3; ++c) {
      f_[3 * i + c] = fs[c];
      t_[3 * i + c] = tsum[c];
    }
  }
}

}  // namespace demfem::builtin
