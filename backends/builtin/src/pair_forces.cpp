// Particle-particle contact forces of the built-in DEM over the half neighbour list
// (docs/builtin-dem.md, "Performance design"). Rows are taken in batches: a first pass finds the
// touching slots of the batch and their squared distances, a second computes every touching
// contact's distance and its inverse at once (independent square roots and divisions, vectorised:
// AVX2 where the CPU has it), and the contact law then runs on each contact without waiting for
// them. The results are those of one contact after the other, bit for bit.
#include "demfem/backends/builtin/simulation.hpp"

#include "contact_kinematics.hpp"
#include "demfem/backends/physics/dem_assert.hpp"

#include <algorithm>
#include <cmath>

namespace demfem::builtin {

using detail::norm2;

namespace {

constexpr std::size_t kBatchContacts = 256;  // touching contacts per batch (rows are not split)

// r = sqrt(r2), rinv = 1 / r for count contacts; the spin norm |w| = sqrt(w2) when w2 is given.
[[gnu::target_clones("avx2", "default")]] void distances(const double* r2, const double* w2, std::size_t count,
                                                         double* r, double* rinv, double* wnorm) {
  for (std::size_t k = 0; k < count; ++k) {
    r[k] = std::sqrt(r2[k]);
    rinv[k] = 1.0 / r[k];
  }
  if (w2)
    for (std::size_t k = 0; k < count; ++k) wnorm[k] = std::sqrt(w2[k]);
}

}  // namespace

void DemSimulation::pairForces(int part) {
  withModel(model_, [&]<study::NormalModel N, study::RollingModel R>() { pairLoop<N, R>(part); });
}

template <study::NormalModel N, study::RollingModel R>
void DemSimulation::pairLoop(int part) {
  const std::size_t n = particleCount();
  const int H = layout_.size;
  const double dt = dt_, rolling_dt = rollingStep();
  constexpr bool kRollingNorm = R == study::RollingModel::Cdt;  // the law needs |w_i - w_j|
  PartState& ts = part_[part];
  // Part `part` owns rows [lo, hi); it writes particles [lo, window_end) only (half list: j > i),
  // so its buffer is cleared and summed over that window alone.
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part), window_end = part_window_end_[part];
  DEMFEM_ASSERT(nb_start_.size() == n + 1 && window_end >= hi && window_end <= n);
  double* F = f_.data();
  double* Tq = t_.data();
  if (threads_ > 1) {
    ts.f.resize(3 * n);
    ts.t.resize(3 * n);
    std::fill(ts.f.begin() + 3 * lo, ts.f.begin() + 3 * window_end, 0.0);
    std::fill(ts.t.begin() + 3 * lo, ts.t.begin() + 3 * window_end, 0.0);
    F = ts.f.data();
    Tq = ts.t.data();
  }
  double local_max = 0;
  std::int64_t bad = -1;
  for (std::size_t i0 = lo; i0 < hi;) {
    // Pass 1: rows [i0, i1) until the batch holds kBatchContacts slots; touching slots and their
    // squared distances (a slot that stopped touching loses its history).
    ts.batch_slot.clear();
    ts.batch_r2.clear();
    ts.batch_w2.clear();
    std::size_t i1 = i0;
    for (; i1 < hi && static_cast<std::size_t>(nb_start_[i1] - nb_start_[i0]) < kBatchContacts; ++i1) {
      const double xi = x_[3 * i1], yi = x_[3 * i1 + 1], zi = x_[3 * i1 + 2];
      const double ri = radius_[i1];
      for (std::int32_t s = nb_start_[i1]; s < nb_start_[i1 + 1]; ++s) {
        const std::size_t j = static_cast<std::size_t>(nb_j_[s]);
        DEMFEM_ASSERT(j > i1 && j < window_end);
        const double d[3] = {xi - x_[3 * j], yi - x_[3 * j + 1], zi - x_[3 * j + 2]};
        const double rs = ri + radius_[j];
        const double r2 = norm2(d);
        if (r2 >= rs * rs) {
          if (nb_touch_[s]) {
            nb_touch_[s] = 0;
            std::fill_n(nb_hist_.data() + static_cast<std::size_t>(s) * H, H, 0.0);
          }
          continue;
        }
        if (!nb_touch_[s]) nb_touch_[s] = 1;
        ts.batch_slot.push_back(s);
        ts.batch_r2.push_back(r2);
        if constexpr (kRollingNorm) {
          const double wr[3] = {w_[3 * i1] - w_[3 * j], w_[3 * i1 + 1] - w_[3 * j + 1], w_[3 * i1 + 2] - w_[3 * j + 2]};
          ts.batch_w2.push_back(norm2(wr));
        }
      }
    }
    // Pass 2: the distances of all touching contacts of the batch.
    const std::size_t count = ts.batch_slot.size();
    ts.batch_r.resize(count);
    ts.batch_rinv.resize(count);
    ts.batch_wnorm.resize(count);
    distances(ts.batch_r2.data(), kRollingNorm ? ts.batch_w2.data() : nullptr, count, ts.batch_r.data(),
              ts.batch_rinv.data(), ts.batch_wnorm.data());
    // Pass 3: the law, row by row; i's sums stay in registers over its row.
    std::size_t k = 0;
    for (std::size_t i = i0; i < i1; ++i) {
      const double xi = x_[3 * i], yi = x_[3 * i + 1], zi = x_[3 * i + 2];
      const double ri = radius_[i];
      const PairLaw* laws_i = &table_.law(material_[i], 0);  // row of i's material
      double fi[3] = {0, 0, 0}, ti[3] = {0, 0, 0};
      for (; k < count && ts.batch_slot[k] < nb_start_[i + 1]; ++k) {
        const std::int32_t s = ts.batch_slot[k];
        const std::size_t j = static_cast<std::size_t>(nb_j_[s]);
        const double rj = radius_[j];
        const double rinv = ts.batch_rinv[k];
        const double normal[3] = {(xi - x_[3 * j]) * rinv, (yi - x_[3 * j + 1]) * rinv, (zi - x_[3 * j + 2]) * rinv};
        ContactKinematics kin =
            contactKinematics<false>(normal, ts.batch_r[k], ri, rj, &v_[3 * i], &w_[3 * i], &v_[3 * j], &w_[3 * j]);
        kin.wrel_norm = ts.batch_wnorm[k];
        kin.inv_ii = inv_inertia_[i];
        kin.inv_ij = inv_inertia_[j];
        if (kin.delta > local_max) local_max = kin.delta;
        if (kin.delta > overlapLimitFraction() * std::min(ri, rj) && bad < 0) bad = static_cast<std::int64_t>(i);
        const ContactResult res = contactForce<N, R>(model_, layout_, laws_i[material_[j]], nb_stiff_[s], kin, dt, rolling_dt,
                                                     nb_hist_.data() + static_cast<std::size_t>(s) * H, false);
        for (int c = 0; c < 3; ++c) {
          fi[c] += res.force[c];
          F[3 * j + c] -= res.force[c];
          ti[c] += res.torque_i[c];
          Tq[3 * j + c] += res.torque_j[c];
        }
      }
      for (int c = 0; c < 3; ++c) {
        F[3 * i + c] += fi[c];
        Tq[3 * i + c] += ti[c];
      }
    }
    i0 = i1;
  }
  ts.pair_max = local_max;
  ts.pair_bad = bad;
}

// With more than one part: each particle of this part's range adds the buffers of the parts
// whose window holds it, in part order (the same sums for any partition of the particles).
void DemSimulation::sumPairForces(int part) {
  if (threads_ == 1) return;
  const std::size_t n = particleCount();
  for (std::size_t i = rangeBegin(part); i < rangeEnd(part); ++i) {
    double fs[3] = {f_[3 * i], f_[3 * i + 1], f_[3 * i + 2]};
    double tsum[3] = {t_[3 * i], t_[3 * i + 1], t_[3 * i + 2]};
    for (int t = 0; t < threads_; ++t) {
      if (i < n * t / threads_ || i >= part_window_end_[t]) continue;
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
