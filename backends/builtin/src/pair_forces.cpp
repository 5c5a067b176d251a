// Particle-particle contact forces of the built-in DEM over the half neighbour list
// (docs/builtin-dem.md, "Performance design").
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_assert.hpp"

#include "contact_kinematics.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace demfem::builtin {

using detail::norm2;

void DemSimulation::pairForces() {
  withModel(model_, [&]<study::NormalModel N, study::RollingModel R>() { pairLoop<N, R>(); });
}

template <study::NormalModel N, study::RollingModel R>
void DemSimulation::pairLoop() {
  const std::size_t n = particleCount();
  const int T = threads_;
  const int H = layout_.size;
  const double dt = dt_;
  std::vector<double> thread_max(T, 0.0);
  std::vector<std::int64_t> thread_bad(T, -1);
#pragma omp parallel num_threads(T)
  {
    const int tid = omp_get_thread_num();
    // Thread tid owns rows [lo, hi); it writes particles [lo, window_end) only (half list: j > i),
    // so its buffer is cleared and summed over that window alone.
    const std::size_t lo = n * tid / T, hi = n * (tid + 1) / T, window_end = thread_window_end_[tid];
    DEMFEM_ASSERT(nb_start_.size() == n + 1 && window_end >= hi && window_end <= n);
    double* F = f_.data();
    double* Tq = t_.data();
    if (T > 1) {
      thread_f_[tid].resize(3 * n);
      thread_t_[tid].resize(3 * n);
      std::fill(thread_f_[tid].begin() + 3 * lo, thread_f_[tid].begin() + 3 * window_end, 0.0);
      std::fill(thread_t_[tid].begin() + 3 * lo, thread_t_[tid].begin() + 3 * window_end, 0.0);
      F = thread_f_[tid].data();
      Tq = thread_t_[tid].data();
    }
    double local_max = 0;
    std::int64_t bad = -1;
    for (std::size_t i = lo; i < hi; ++i) {
      const double xi = x_[3 * i], yi = x_[3 * i + 1], zi = x_[3 * i + 2];
      const double ri = radius_[i];
      const PairLaw* laws_i = &table_.law(material_[i], 0);  // row of i's material
      // i's sums stay in registers over its row (no store-load chain through F[i] per contact).
      double fi[3] = {0, 0, 0}, ti[3] = {0, 0, 0};
      for (std::int32_t s = nb_start_[i]; s < nb_start_[i + 1]; ++s) {
        const std::size_t j = static_cast<std::size_t>(nb_j_[s]);
        DEMFEM_ASSERT(j > i && j < window_end);
        const double d[3] = {xi - x_[3 * j], yi - x_[3 * j + 1], zi - x_[3 * j + 2]};
        const double rj = radius_[j];
        const double rs = ri + rj;
        const double r2 = norm2(d);
        double* hist = nb_hist_.data() + static_cast<std::size_t>(s) * H;
        if (r2 >= rs * rs) {
          if (nb_touch_[s]) {
            nb_touch_[s] = 0;
            for (int h = 0; h < H; ++h) hist[h] = 0;
          }
          continue;
        }
        if (!nb_touch_[s]) nb_touch_[s] = 1;
        const double r = std::sqrt(r2);
        const double rinv = 1.0 / r;
        const double normal[3] = {d[0] * rinv, d[1] * rinv, d[2] * rinv};
        const ContactKinematics k =
            contactKinematics<false>(normal, r, ri, rj, &v_[3 * i], &w_[3 * i], &v_[3 * j], &w_[3 * j]);
        if (k.delta > local_max) local_max = k.delta;
        if (k.delta > overlapLimitFraction() * std::min(ri, rj) && bad < 0) bad = static_cast<std::int64_t>(i);
        const ContactResult res =
            contactForce<N, R>(model_, layout_, laws_i[material_[j]], nb_stiff_[s], k, dt, hist, false);
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
    thread_max[tid] = local_max;
    thread_bad[tid] = bad;
    if (T > 1) {  // every thread takes this branch
#pragma omp barrier
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < n; ++i) {
        double fs[3] = {f_[3 * i], f_[3 * i + 1], f_[3 * i + 2]};
        double ts[3] = {t_[3 * i], t_[3 * i + 1], t_[3 * i + 2]};
        for (int t = 0; t < T; ++t) {
          if (i < n * t / T || i >= thread_window_end_[t]) continue;
          for (int c = 0; c < 3; ++c) {
            fs[c] += thread_f_[t][3 * i + c];
            ts[c] += thread_t_[t][3 * i + c];
          }
        }
        for (int c = 0; c < 3; ++c) {
          f_[3 * i + c] = fs[c];
          t_[3 * i + c] = ts[c];
        }
      }
    }
  }
  max_overlap_ = *std::max_element(thread_max.begin(), thread_max.end());
  for (int t = 0; t < T; ++t)
    if (thread_bad[t] >= 0) {
      const std::size_t i = static_cast<std::size_t>(thread_bad[t]);
      std::ostringstream msg;
      msg << "overlap with a neighbour exceeds " << overlapLimitFraction() << " of the smaller radius (largest overlap "
          << max_overlap_ * 1e3 << " mm); the time step may be too large for the contact stiffness";
      fail(i, msg.str());
    }
}

}  // namespace demfem::builtin
