#include "demfem/adapter/settled_soil.hpp"

#include "demfem/adapter/output_files.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numbers>
#include <stdexcept>
#include <cerrno>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

namespace demfem::adapter {

namespace {

constexpr char kMagic[8] = {'D', 'F', 'S', 'O', 'I', 'L', 'N', 'T'};
constexpr std::size_t kParticleBytes = 36;
constexpr std::size_t kMaxHeaderBytes = 1 << 16;

template <class T>
void append(std::string& bytes, const T& value) {
  bytes.append(reinterpret_cast<const char*>(&value), sizeof value);
}

template <class T>
T take(const std::string& bytes, std::size_t& at) {
  T value;
  std::memcpy(&value, bytes.data() + at, sizeof value);
  at += sizeof value;
  return value;
}

std::string hex16(std::uint64_t value) {
  char text[17];
  std::snprintf(text, sizeof text, "%016llx", static_cast<unsigned long long>(value));
  return text;
}

nlohmann::json headerJson(const SettledSoil& soil) {
  const SettlingFigures& s = soil.settling;
  return {{"soil_hash", soil.soil_hash},
          {"deposition",
           {{"backend", soil.backend}, {"seed", soil.seed}, {"cores", soil.cores}}},
          {"settling",
           {{"kinetic_energy_J", s.kinetic_energy_J},
            {"threshold_J", s.threshold_J},
            {"stages", s.stages},
            {"stages_capped", s.stages_capped},
            {"final_phase_capped", s.final_phase_capped},
            {"simulated_s", s.simulated_s},
            {"surface_height_m", s.surface_height_m},
            {"packing_fraction", s.packing_fraction},
            {"bulk_density_kg_m3", s.bulk_density_kg_m3},
            {"coordination_number", s.coordination_number},
            {"target_bulk_density_kg_m3", s.target_bulk_density_kg_m3},
            {"pour_friction_scale", s.pour_friction_scale}}},
          {"particle_count", soil.particles.size()}};
}

// The whole file, read and checked: magic, version, checksum, header and length.
struct CheckedSoilFile {
  std::string bytes;
  nlohmann::json header;
  std::size_t particles_at = 0;
  std::uint64_t checksum = 0;
};

CheckedSoilFile readChecked(const std::filesystem::path& file) {
  const auto fail = [&file](const std::string& what) {
    return std::runtime_error("settled soil file " + file.string() + ": " + what +
                              " (delete it and deposit the soil again: demfem deposit STUDY)");
  };
  std::ifstream in(file, std::ios::binary);
  if (!in) throw fail("cannot be opened");
  CheckedSoilFile f;
  f.bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) throw fail("read error");
  const std::string& b = f.bytes;
  if (b.size() < sizeof kMagic + 8 || std::memcmp(b.data(), kMagic, sizeof kMagic) != 0)
    throw fail("not a settled-soil file (magic \"DFSOILNT\" missing)");
  std::size_t at = sizeof kMagic;
  const auto version = take<std::uint32_t>(b, at);
  if (version != kSettledSoilFormatVersion)
    throw fail("format version " + std::to_string(version) + ", this demfem reads version " +
               std::to_string(kSettledSoilFormatVersion));
  const auto header_bytes = take<std::uint32_t>(b, at);
  if (header_bytes > kMaxHeaderBytes || at + header_bytes + 8 > b.size())
    throw fail("truncated (header of " + std::to_string(header_bytes) + " bytes announced, file has " +
               std::to_string(b.size()) + ")");
  std::size_t end = b.size() - 8;
  f.checksum = take<std::uint64_t>(b, end);
  if (f.checksum != study::fnv1a64(std::string_view(b.data(), b.size() - 8)))
    throw fail("checksum mismatch: the file is damaged or truncated");
  try {
    f.header = nlohmann::json::parse(b.substr(at, header_bytes));
  } catch (const nlohmann::json::exception& e) {
    throw fail(std::string("header is not JSON: ") + e.what());
  }
  f.particles_at = at + header_bytes;
  return f;
}

}  // namespace

void writeSettledSoil(const std::filesystem::path& file, const SettledSoil& soil) {
  const std::string header = headerJson(soil).dump();
  std::string bytes(kMagic, sizeof kMagic);
  append(bytes, kSettledSoilFormatVersion);
  append(bytes, static_cast<std::uint32_t>(header.size()));
  bytes += header;
  bytes.reserve(bytes.size() + soil.particles.size() * kParticleBytes + 8);
  for (const SoilParticle& p : soil.particles) {
    for (double c : p.x_m) append(bytes, c);
    append(bytes, p.radius_m);
    append(bytes, p.layer);
  }
  append(bytes, study::fnv1a64(bytes));

  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  // Concurrent depositions of one soil write their own temporaries (output_files.hpp).
  try {
    writeFileAtomically(file, bytes);
  } catch (const OutputError& e) {
    throw std::runtime_error("settled soil file " + file.string() + ": " + e.what());
  }
}

bool depositOnce(const std::filesystem::path& file, const std::function<SettledSoil()>& deposit, bool replace) {
  if (file.has_parent_path()) std::filesystem::create_directories(file.parent_path());
  const std::filesystem::path lock = file.string() + ".lock";
  const int fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("settled soil lock " + lock.string() + ": cannot open (" + std::strerror(errno) + ")");
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }  // closing the descriptor drops the lock
  } closer{fd};
  int status;
  while ((status = ::flock(fd, LOCK_EX)) != 0 && errno == EINTR) {
  }
  if (status != 0) throw std::runtime_error("settled soil lock " + lock.string() + ": cannot lock (" + std::strerror(errno) + ")");
  if (std::filesystem::exists(file) && !replace) return false;
  writeSettledSoil(file, deposit());
  return true;
}

SettledSoil readSettledSoil(const std::filesystem::path& file) {
  const CheckedSoilFile f = readChecked(file);
  const auto fail = [&file](const std::string& what) {
    return std::runtime_error("settled soil file " + file.string() + ": " + what);
  };
  SettledSoil soil;
  std::uint64_t count = 0;
  try {
    const auto& h = f.header;
    soil.soil_hash = h.at("soil_hash").get<std::string>();
    const auto& d = h.at("deposition");
    soil.backend = d.at("backend").get<std::string>();
    soil.seed = d.at("seed").get<std::uint64_t>();
    soil.cores = d.at("cores").get<std::int32_t>();
    const auto& s = h.at("settling");
    soil.settling = {s.at("kinetic_energy_J").get<double>(), s.at("threshold_J").get<double>(),
                     s.at("stages").get<std::int32_t>(),     s.at("stages_capped").get<std::int32_t>(),
                     s.at("final_phase_capped").get<bool>(), s.at("simulated_s").get<double>(),      s.at("surface_height_m").get<double>(),
                     s.at("packing_fraction").get<double>(), s.at("bulk_density_kg_m3").get<double>(),
                     s.at("coordination_number").get<double>(), s.at("target_bulk_density_kg_m3").get<double>(),
                     s.at("pour_friction_scale").get<double>()};
    count = h.at("particle_count").get<std::uint64_t>();
  } catch (const std::exception& e) {
    throw fail(std::string("header: ") + e.what());
  }
  const std::size_t payload = f.bytes.size() - 8 - f.particles_at;
  if (payload != count * kParticleBytes)
    throw fail(std::to_string(count) + " particles announced, " + std::to_string(payload) + " bytes of particles");
  soil.particles.resize(count);
  std::size_t at = f.particles_at;
  for (SoilParticle& p : soil.particles) {
    for (double& c : p.x_m) c = take<double>(f.bytes, at);
    p.radius_m = take<double>(f.bytes, at);
    p.layer = take<std::int32_t>(f.bytes, at);
  }
  return soil;
}

SettledSoil readSettledSoil(const std::filesystem::path& file, const study::Study& study) {
  SettledSoil soil = readSettledSoil(file);
  const std::string hash = study::soilHash(study);
  if (soil.soil_hash != hash)
    throw std::runtime_error("settled soil file " + file.string() + ": soil hash " + soil.soil_hash +
                             ", the study's is " + hash);
  const auto layers = static_cast<std::int32_t>(study.soil.layers.size());
  for (std::size_t i = 0; i < soil.particles.size(); ++i)
    if (soil.particles[i].layer < 0 || soil.particles[i].layer >= layers)
      throw std::runtime_error("settled soil file " + file.string() + ": particle " + std::to_string(i) + " has layer " +
                               std::to_string(soil.particles[i].layer) + ", /soil/layers has " +
                               std::to_string(layers));
  return soil;
}

std::string settledSoilChecksum(const std::filesystem::path& file) { return hex16(readChecked(file).checksum); }

std::filesystem::path settledSoilFile(const study::Study& study, const std::filesystem::path& dir) {
  return dir / ("soil-" + study::soilHash(study) + ".bin");
}

std::filesystem::path defaultSoilDirectory() {
  if (const char* env = std::getenv("DEMFEM_SOIL_DIR"); env && *env) return env;
  return "soil";
}

double soilSurfaceHeight(const std::vector<SoilParticle>& particles, double diameter_max_m) {
  double highest = 0;
  for (const auto& p : particles) highest = std::max(highest, p.x_m[1] + p.radius_m);
  double sum = 0;
  std::size_t count = 0;
  for (const auto& p : particles)
    if (p.x_m[1] + p.radius_m > highest - diameter_max_m) sum += p.x_m[1] + p.radius_m, ++count;
  return count ? sum / static_cast<double>(count) : 0.0;
}

double packingFraction(const std::vector<SoilParticle>& particles, const study::Soil& soil) {
  double volume = 0;
  for (const auto& p : particles) volume += 4.0 / 3.0 * std::numbers::pi * p.radius_m * p.radius_m * p.radius_m;
  return volume / (soil.bin_width_m * soil.bin_length_m * soil.fill_height_m);
}

double bulkDensity(const std::vector<SoilParticle>& particles, const study::Soil& soil) {
  std::vector<double> density(soil.layers.size(), -1.0);
  for (std::size_t l = 0; l < soil.layers.size(); ++l)
    for (const auto& m : soil.materials)
      if (m.name == soil.layers[l].material) density[l] = m.density_kg_m3;
  double mass = 0;
  for (const auto& p : particles) {
    if (p.layer < 0 || static_cast<std::size_t>(p.layer) >= density.size() || density[static_cast<std::size_t>(p.layer)] < 0)
      throw std::invalid_argument("bulkDensity: particle of layer " + std::to_string(p.layer) +
                                  " has no layer material in /soil/materials");
    mass += density[static_cast<std::size_t>(p.layer)] * 4.0 / 3.0 * std::numbers::pi * p.radius_m * p.radius_m * p.radius_m;
  }
  return mass / (soil.bin_width_m * soil.bin_length_m * soil.fill_height_m);
}

double meanCoordinationNumber(const std::vector<SoilParticle>& particles) {
  if (particles.empty()) return 0;
  double r_max = 0;
  std::array<double, 3> lo{particles[0].x_m}, hi{particles[0].x_m};
  for (const auto& p : particles) {
    r_max = std::max(r_max, p.radius_m);
    for (int c = 0; c < 3; ++c) lo[c] = std::min(lo[c], p.x_m[c]), hi[c] = std::max(hi[c], p.x_m[c]);
  }
  // Cells of one largest diameter: a touching pair is in the same or a neighbouring cell.
  const double cell = std::max(2 * r_max, 1e-12);
  std::array<long, 3> n{};
  for (int c = 0; c < 3; ++c) n[c] = static_cast<long>((hi[c] - lo[c]) / cell) + 1;
  const auto index = [&](const SoilParticle& p, int c) {
    return std::min(n[c] - 1, static_cast<long>((p.x_m[c] - lo[c]) / cell));
  };
  std::vector<std::vector<std::size_t>> cells(static_cast<std::size_t>(n[0] * n[1] * n[2]));
  for (std::size_t i = 0; i < particles.size(); ++i)
    cells[static_cast<std::size_t>((index(particles[i], 2) * n[1] + index(particles[i], 1)) * n[0] + index(particles[i], 0))]
        .push_back(i);
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < particles.size(); ++i) {
    const auto& a = particles[i];
    const long cx = index(a, 0), cy = index(a, 1), cz = index(a, 2);
    for (long z = std::max(0L, cz - 1); z <= std::min(n[2] - 1, cz + 1); ++z)
      for (long y = std::max(0L, cy - 1); y <= std::min(n[1] - 1, cy + 1); ++y)
        for (long x = std::max(0L, cx - 1); x <= std::min(n[0] - 1, cx + 1); ++x)
          for (const std::size_t j : cells[static_cast<std::size_t>((z * n[1] + y) * n[0] + x)]) {
            if (j <= i) continue;
            const auto& b = particles[j];
            const double dx = a.x_m[0] - b.x_m[0], dy = a.x_m[1] - b.x_m[1], dz = a.x_m[2] - b.x_m[2];
            const double reach = a.radius_m + b.radius_m;
            if (dx * dx + dy * dy + dz * dz < reach * reach) ++pairs;
          }
  }
  return 2.0 * static_cast<double>(pairs) / static_cast<double>(particles.size());
}

std::string unsettledReason(const SettlingFigures& s) {
  std::string reason;
  if (s.final_phase_capped) reason = "the final settling phase hit its time cap above the kinetic-energy threshold";
  if (!(s.kinetic_energy_J < s.threshold_J)) {
    char text[160];
    std::snprintf(text, sizeof text, "final kinetic energy %.3g J is not below soil.deposition.settle_kinetic_energy_J = %.3g J",
                  s.kinetic_energy_J, s.threshold_J);
    reason += (reason.empty() ? "" : "; ") + std::string(text);
  }
  return reason;
}

std::string unsettledSoilMessage(const std::filesystem::path& file, const SettlingFigures& settling) {
  const std::string reason = unsettledReason(settling);
  if (reason.empty()) return reason;
  return "the settled soil " + file.string() + " is not settled: " + reason +
         ". Raise soil.deposition.settle_kinetic_energy_J and deposit it again (demfem deposit --force), "
         "or run on it anyway with --allow-unsettled-soil";
}

std::string soilRecordJson(const SettledSoil& soil, const std::filesystem::path& file, const std::string& checksum) {
  const SettlingFigures& s = soil.settling;
  const nlohmann::json record{{"file", file.string()},
                              {"file_checksum", checksum},
                              {"soil_hash", soil.soil_hash},
                              {"deposition_backend", soil.backend},
                              {"deposition_seed", soil.seed},
                              {"deposition_cores", soil.cores},
                              {"particles", soil.particles.size()},
                              {"settled", unsettledReason(s).empty()},
                              {"kinetic_energy_J", s.kinetic_energy_J},
                              {"threshold_J", s.threshold_J},
                              {"stages", s.stages},
                              {"stages_capped", s.stages_capped},
                              {"final_phase_capped", s.final_phase_capped},
                              {"simulated_s", s.simulated_s},
                              {"surface_height_mm", s.surface_height_m * 1e3},
                              {"packing_fraction", s.packing_fraction},
                              {"bulk_density_kg_m3", s.bulk_density_kg_m3},
                              {"coordination_number", s.coordination_number},
                              {"target_bulk_density_kg_m3",
                               s.target_bulk_density_kg_m3 > 0 ? nlohmann::json(s.target_bulk_density_kg_m3) : nlohmann::json()},
                              {"pour_friction_scale", s.pour_friction_scale}};
  return record.dump();
}

}  // namespace demfem::adapter
