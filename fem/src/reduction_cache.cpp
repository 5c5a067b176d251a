#include "demfem/fem/reduction_cache.hpp"

#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/output_files.hpp"
#include "demfem/study/study.hpp"

#include <cstdio>
#include <cstdlib>
#include <stdexcept>
#include <vector>

namespace demfem::fem {

namespace {

constexpr const char* kReductionKind = "fem-reduction";
constexpr const char* kModalKind = "fem-modal-basis";
constexpr const char* kReductionPrefix = "reduction";  // the file names of reduction_cache.hpp
constexpr const char* kModalPrefix = "modal";

template <class T> void append(std::string& bytes, const T* values, std::size_t count) {
  bytes.append(reinterpret_cast<const char*>(values), count * sizeof(T));
}

void appendSparse(std::string& bytes, const SparseMatrix& m) {
  SparseMatrix compressed = m;
  compressed.makeCompressed();
  const std::int64_t shape[3] = {compressed.rows(), compressed.cols(), compressed.nonZeros()};
  append(bytes, shape, 3);
  append(bytes, compressed.outerIndexPtr(), static_cast<std::size_t>(compressed.cols()) + 1);
  append(bytes, compressed.innerIndexPtr(), static_cast<std::size_t>(compressed.nonZeros()));
  append(bytes, compressed.valuePtr(), static_cast<std::size_t>(compressed.nonZeros()));
}

void appendInts(std::string& bytes, const std::vector<int>& values) {
  const std::uint64_t n = values.size();
  append(bytes, &n, 1);
  append(bytes, values.data(), values.size());
}

// The lower triangle of a symmetric matrix, column by column (reduce() makes K and M exactly
// symmetric, so the upper one carries nothing).
std::vector<double> lowerTriangle(const Eigen::MatrixXd& m) {
  std::vector<double> values;
  values.reserve(static_cast<std::size_t>(m.rows() * (m.rows() + 1) / 2));
  for (Eigen::Index c = 0; c < m.cols(); ++c)
    for (Eigen::Index r = c; r < m.rows(); ++r) values.push_back(m(r, c));
  return values;
}

Eigen::MatrixXd symmetricFromLower(const std::vector<double>& values, Eigen::Index n) {
  Eigen::MatrixXd m(n, n);
  std::size_t k = 0;
  for (Eigen::Index c = 0; c < n; ++c)
    for (Eigen::Index r = c; r < n; ++r) m(r, c) = m(c, r) = values[k++];
  return m;
}

void writeReduction(const ReducedModel& r, adapter::PayloadWriter& out) {
  out.put(static_cast<std::uint64_t>(r.dofCount()));
  out.putVector(std::vector<double>(r.keypoints.data(), r.keypoints.data() + r.keypoints.size()));
  out.put(r.length_m);
  out.putVector(r.constraints.fixed_dofs);
  out.putVector(r.constraints.load_cell_dofs);
  std::vector<int> spring_dofs;
  std::vector<double> spring_stiffness;
  for (const auto& [dof, k] : r.constraints.springs) spring_dofs.push_back(dof), spring_stiffness.push_back(k);
  out.putVector(spring_dofs);
  out.putVector(spring_stiffness);
  out.putVector(lowerTriangle(r.K));
  out.putVector(lowerTriangle(r.M));
}

ReducedModel readReduction(adapter::PayloadReader& in) {
  const auto n = in.get<std::uint64_t>();
  ReducedModel r;
  const auto keypoints = in.getVector<double>();
  if (keypoints.size() != n) in.fail(std::to_string(keypoints.size()) + " keypoint coordinates for " + std::to_string(n) + " DOFs");
  r.keypoints.resize(static_cast<Eigen::Index>(n / 3), 3);
  std::copy(keypoints.begin(), keypoints.end(), r.keypoints.data());
  in.get(r.length_m);
  in.getVector(r.constraints.fixed_dofs);
  in.getVector(r.constraints.load_cell_dofs);
  const auto spring_dofs = in.getVector<int>();
  const auto spring_stiffness = in.getVector<double>();
  if (spring_dofs.size() != spring_stiffness.size()) in.fail("spring DOFs and stiffnesses differ in number");
  for (std::size_t i = 0; i < spring_dofs.size(); ++i) r.constraints.springs.emplace_back(spring_dofs[i], spring_stiffness[i]);
  const auto K = in.getVector<double>();
  const auto M = in.getVector<double>();
  in.finish();
  if (K.size() != n * (n + 1) / 2 || M.size() != K.size()) in.fail("K and M are not the lower triangles of " + std::to_string(n) + " DOFs");
  r.K = symmetricFromLower(K, static_cast<Eigen::Index>(n));
  r.M = symmetricFromLower(M, static_cast<Eigen::Index>(n));
  return r;
}

std::string hexOf(std::uint64_t value) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(value));
  return hex;
}

// The one name of a cache file: dir/<prefix>-<hash>.bin.
std::filesystem::path cacheFile(const std::filesystem::path& dir, const std::string& prefix, const std::string& hash) {
  return dir / (prefix + "-" + hash + ".bin");
}

// The value kept in cacheFile(dir, prefix, hash) (container kind `kind`; after the hash its payload is
// read by `read`), else `compute()` written there by `write` (reduction_cache.hpp, contract).
template <class Read, class Compute, class Write>
auto cachedValue(const std::filesystem::path& dir, const std::string& prefix, const std::string& hash, const char* kind,
                 const std::string& description, Read read, Compute compute, Write write) -> decltype(compute()) {
  const std::filesystem::path file = cacheFile(dir, prefix, hash);
  if (std::filesystem::exists(file)) {
    try {
      const std::string payload = adapter::readCheckpointFile(file, kind, description);
      adapter::PayloadReader in(payload, description + " " + file.string());
      if (const std::string recorded = in.getString(); recorded != hash)
        in.fail("records the hash " + recorded + ", not its name's " + hash);
      return read(in);
    } catch (const adapter::CouplingError& e) {
      throw std::runtime_error(std::string(e.what()) + "; delete the file and the next run computes it again");
    }
  }
  auto value = compute();
  std::error_code error;
  std::filesystem::create_directories(dir, error);
  if (error) throw adapter::OutputError("cannot create the FEM cache directory " + dir.string() + ": " + error.message());
  adapter::PayloadWriter out;
  out.putString(hash);
  write(value, out);
  adapter::writeFileAtomically(file, adapter::checkpointImage(kind, out.bytes()));
  return value;
}

void writeModal(const ModalBasis& b, adapter::PayloadWriter& out) {
  out.put(static_cast<std::uint64_t>(b.phi.rows()));
  out.put(b.highest_mode_Hz);
  out.putVector(std::vector<double>(b.omega2.data(), b.omega2.data() + b.omega2.size()));
  out.putVector(std::vector<double>(b.phi.data(), b.phi.data() + b.phi.size()));
  out.putVector(lowerTriangle(b.residual));
}

ModalBasis readModal(adapter::PayloadReader& in) {
  const auto free = in.get<std::uint64_t>();
  ModalBasis b;
  in.get(b.highest_mode_Hz);
  const auto omega2 = in.getVector<double>();
  const auto phi = in.getVector<double>();
  const auto residual = in.getVector<double>();
  in.finish();
  if (omega2.empty() || phi.size() != free * omega2.size() || residual.size() != free * (free + 1) / 2)
    in.fail("its modes and R do not fit " + std::to_string(free) + " free DOFs");
  b.omega2 = Eigen::Map<const Eigen::ArrayXd>(omega2.data(), static_cast<Eigen::Index>(omega2.size()));
  b.phi = Eigen::Map<const Eigen::MatrixXd>(phi.data(), static_cast<Eigen::Index>(free), static_cast<Eigen::Index>(omega2.size()));
  b.residual = symmetricFromLower(residual, static_cast<Eigen::Index>(free));
  return b;
}

}  // namespace

std::string fullModelHash(const FullModel& model) {
  std::string bytes = "demfem-reduction-v" + std::to_string(kFemCacheVersion) + '\n';
  appendSparse(bytes, model.K);
  appendSparse(bytes, model.M);
  appendInts(bytes, model.keypoint_nodes);
  append(bytes, model.keypoints.data(), static_cast<std::size_t>(model.keypoints.size()));
  appendInts(bytes, model.constraints.fixed_dofs);
  appendInts(bytes, model.constraints.load_cell_dofs);
  for (const auto& [dof, k] : model.constraints.springs) append(bytes, &dof, 1), append(bytes, &k, 1);
  append(bytes, &model.length_m, 1);
  return hexOf(study::fnv1a64(bytes));
}

std::filesystem::path reductionFile(const FullModel& model, const std::filesystem::path& dir) {
  return cacheFile(dir, kReductionPrefix, fullModelHash(model));
}

ReducedModel reduceCached(const FullModel& model, const std::filesystem::path& dir, const std::function<void(double)>& progress) {
  const std::string hash = fullModelHash(model);
  return cachedValue(
      dir, kReductionPrefix, hash, kReductionKind, "keypoint reduction cache",
      [&](adapter::PayloadReader& in) {
        ReducedModel r = readReduction(in);
        if (progress) progress(1.0);
        return r;
      },
      [&] { return reduce(model, progress); }, writeReduction);
}

ModalBasis modalBasisCached(const FullModel& full, const ReducedModel& reduced, double dt_s, const std::filesystem::path& dir) {
  const double truncation = kQuasiStaticOmegaDt;
  std::string key = fullModelHash(full);
  key.append(reinterpret_cast<const char*>(&dt_s), sizeof dt_s).append(reinterpret_cast<const char*>(&truncation), sizeof truncation);
  const std::string hash = hexOf(study::fnv1a64(key));
  return cachedValue(dir, kModalPrefix, hash, kModalKind, "modal basis cache", readModal,
                     [&] { return modalBasis(reduced, dt_s, truncation); }, writeModal);
}

std::filesystem::path defaultReductionDirectory() {
  if (const char* env = std::getenv("DEMFEM_FEM_CACHE_DIR"); env && *env) return env;
  return "fem-cache";
}

}  // namespace demfem::fem
