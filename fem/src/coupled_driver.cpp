#include "demfem/fem/coupled_driver.hpp"

#include "demfem/fem/integrator.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>

namespace demfem::fem {

namespace fs = std::filesystem;
using adapter::NodeArray;

namespace {

constexpr char kCheckpointMagic[] = "demfem-coupled-fem-state-1";

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

// One output file written as NAME.partial and renamed when closed.
class StagedFile {
 public:
  StagedFile(fs::path final_path, bool binary) : final_(std::move(final_path)), binary_(binary) {}

  void open(bool resume, std::uint64_t resume_size) {
    const fs::path partial = partialPath();
    if (resume) {
      if (!fs::exists(partial) && fs::exists(final_)) fs::rename(final_, partial);
      if (!fs::exists(partial)) throw std::runtime_error("cannot resume: " + partial.string() + " is missing");
      if (fs::file_size(partial) < resume_size)
        throw std::runtime_error("cannot resume: " + partial.string() + " is shorter than at the checkpoint");
      fs::resize_file(partial, resume_size);
      out_.open(partial, std::ios::binary | std::ios::app);
    } else {
      out_.open(partial, std::ios::binary | std::ios::trunc);
    }
    if (!out_) throw std::runtime_error("cannot write " + partial.string());
  }
  std::ofstream& stream() { return out_; }
  std::uint64_t flushedSize() {
    out_.flush();
    if (!out_) throw std::runtime_error("writing " + partialPath().string() + " failed");
    return static_cast<std::uint64_t>(fs::file_size(partialPath()));
  }
  void close(const std::string& incomplete_reason) {
    if (!out_.is_open()) return;
    if (!incomplete_reason.empty() && !binary_) out_ << "# incomplete: " << incomplete_reason << '\n';
    out_.close();
    fs::rename(partialPath(), final_);
  }

 private:
  fs::path partialPath() const { return final_.string() + ".partial"; }
  fs::path final_;
  bool binary_;
  std::ofstream out_;
};

void writeVector(std::ofstream& out, const Eigen::VectorXd& v) {
  const std::uint64_t n = static_cast<std::uint64_t>(v.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(double)));
}

Eigen::VectorXd readVector(std::ifstream& in, std::int64_t expected) {
  std::uint64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!in || n != static_cast<std::uint64_t>(expected)) throw std::runtime_error("checkpoint vector size differs from the model");
  Eigen::VectorXd v(expected);
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(double)));
  return v;
}

template <class T> void put(std::ofstream& out, const T& v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); }
template <class T> T get(std::ifstream& in) {
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof v);
  return v;
}

// What the driver carries between steps besides the integrator (checkpointed with it).
struct DriverState {
  std::int64_t step = 0;
  std::int64_t drag_rows = 0;
  double force_sum_N = 0;
  double force_max_N = -std::numeric_limits<double>::infinity();
  std::uint64_t csv_bytes = 0, displacement_bytes = 0;
};

}  // namespace

struct CoupledDriver::Impl {
  Impl(const study::Study& study, CoupledRunOptions options)
      : study_(study), tool_(firstTool(study_)), options_(std::move(options)), dt_(study.fem.dt_s) {
    rigid_ = study_.kind == study::StudyKind::DemOnly || !tool_.fem.deformable;
    if (!rigid_) buildFem();
    planMotion();
  }

  // Connects the FEM model to the DEM's geometry (keypoint matching), once per run.
  void attach() {
    info_ = dem().info();
    findGeometry();
    received_ = dem().nodePositions(tool_.name);
    if (received_.size() != 3 * static_cast<std::size_t>(node_count_))
      throw std::invalid_argument("DEM geometry '" + tool_.name + "' lists " + std::to_string(node_count_) +
                                  " nodes but sent " + std::to_string(received_.size() / 3) + " positions");
    if (!rigid_) match_ = matchKeypoints(*model_, received_, options_.keypoint_tolerance_m);
  }

  adapter::CouplingApi& dem() const { return *dem_; }

  CoupledRunSummary run(adapter::CouplingApi& dem_api) {
    dem_ = &dem_api;
    attach();
    fs::create_directories(options_.output_dir);
    DriverState state;
    if (options_.resume) state = restoreCheckpoint();
    openOutputs(state);
    if (!options_.resume) start();
    CoupledRunSummary summary;
    const auto wall_start = std::chrono::steady_clock::now();
    const std::int64_t first_step = state.step;
    std::string incomplete;
    try {
      while (state.step < total_steps_) {
        if (options_.stop_requested && options_.stop_requested())
          throw CoupledRunInterrupted("interrupted by a stop request at step " + std::to_string(state.step));
        cycle(state);
        if (options_.checkpoint_every > 0 && state.step % options_.checkpoint_every == 0 && state.step < total_steps_)
          writeCheckpoint(state);
        if (options_.on_progress) {
          const double wall = secondsSince(wall_start);
          const double rate = wall > 0 ? static_cast<double>(state.step - first_step) / wall : 0;
          options_.on_progress({state.step, total_steps_, static_cast<double>(state.step) * dt_,
                                static_cast<double>(total_steps_) * dt_, rate,
                                rate > 0 ? static_cast<double>(total_steps_ - state.step) / rate : 0});
        }
      }
    } catch (const std::exception& e) {
      incomplete = e.what();
      closeOutputs(state, incomplete);
      throw;
    }
    closeOutputs(state, "");
    summary.rigid_tool = rigid_;
    summary.steps = state.step;
    summary.drag_steps = state.drag_rows;
    summary.simulated_time_s = static_cast<double>(state.step) * dt_;
    summary.wall_time_s = secondsSince(wall_start);
    summary.mean_force_N = state.drag_rows ? state.force_sum_N / static_cast<double>(state.drag_rows) : 0;
    summary.max_force_N = state.drag_rows ? state.force_max_N : 0;
    summary.final_deformation_mm = last_.deformation_mm;
    summary.final_tilt_deg = last_.tip_tilt_deg;
    summary.backend = info_.backend;
    return summary;
  }

 private:
  static const study::Tool& firstTool(const study::Study& s) {
    if (s.kind != study::StudyKind::Coupled && s.kind != study::StudyKind::DemOnly)
      throw std::invalid_argument("study '" + s.name + "' is not a coupled or DEM-only soil-bin study");
    if (s.tools.empty()) throw std::invalid_argument("study '" + s.name + "' has no tool");
    if (!(s.fem.dt_s > 0)) throw std::invalid_argument("study '" + s.name + "': fem.dt_s must be > 0");
    return s.tools.front();
  }

  static double secondsSince(std::chrono::steady_clock::time_point t) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
  }

  void findGeometry() {
    for (auto& g : dem().geometries())
      if (g.name == tool_.name) {
        node_count_ = g.node_count;
        triangles_ = std::move(g.triangles);
        return;
      }
    throw std::invalid_argument("the DEM backend '" + info_.backend + "' has no geometry named '" + tool_.name +
                                "' (the study's tool)");
  }

  void buildFem() {
    model_ = std::make_unique<ReducedModel>(reduce(buildFullModel(tool_)));
    integrator_ = std::make_unique<ThreeLevelIntegrator>(*model_, dt_, RayleighDamping{tool_.fem.alpha_s, tool_.fem.beta_per_s});
    sensors_ = std::make_unique<Sensors>(*model_, tool_.constraints.sensor_from_top_m);
  }

  void planMotion() {
    const auto& m = tool_.motion;
    if (!(m.velocity_m_s > 0) || !(m.insertion_velocity_m_s > 0) || !(m.stroke_m > 0))
      throw std::invalid_argument("tool '" + tool_.name + "': motion velocities and stroke must be > 0");
    clearance_m_ = study_.soil.diameter_max_m;
    insertion_steps_ = std::max<std::int64_t>(1, static_cast<std::int64_t>(std::ceil((m.depth_m + clearance_m_) / m.insertion_velocity_m_s / dt_ - 1e-9)));
    const auto drag = std::max<std::int64_t>(1, std::llround(m.stroke_m / m.velocity_m_s / dt_));
    total_steps_ = insertion_steps_ + drag;
    if (options_.max_steps) total_steps_ = std::min(total_steps_, *options_.max_steps);
  }

  // Rigid motion of phase `drag` starting at step `from` (bin frame; identity rotation: tool x, y, z
  // are bin x, y, z, DESIGN.md section 10).
  adapter::RigidMotion motion(bool drag) const {
    const auto& m = tool_.motion;
    const double x = 0.5 * study_.soil.bin_width_m, top = study_.soil.fill_height_m;
    // start_z is the bin z of the front face (local z = +T/2); the local origin is the mid-plane.
    const double z = m.start_z_m - 0.5 * tool_.geometry.thickness_m;
    if (!drag) {
      const double v = (m.depth_m + clearance_m_) / (static_cast<double>(insertion_steps_) * dt_);
      return {{x, top + clearance_m_, z}, {0, -v, 0}, t_start_s_};
    }
    return {{x, top - m.depth_m, z}, {0, 0, m.velocity_m_s}, t_start_s_ + static_cast<double>(insertion_steps_) * dt_};
  }

  void start() {
    // The DEM clock need not start at 0 (a settled soil, a restart): motions are timed from it.
    t_start_s_ = dem().time();
    dem().setRigidMotion(tool_.name, motion(false));
    if (!rigid_) integrator_->start(toFem(dem().nodeForces(tool_.name, adapter::ForceMode::Instantaneous)));
  }

  Eigen::VectorXd toFem(const NodeArray& dem_order) const {
    Eigen::VectorXd v(3 * node_count_);
    for (std::size_t i = 0; i < match_.size(); ++i)
      for (int c = 0; c < 3; ++c) v[3 * match_[i] + c] = dem_order[3 * i + c];
    return v;
  }

  NodeArray deformedPositions(const Eigen::VectorXd& u) const {
    NodeArray x(received_.size());
    for (std::size_t i = 0; i < match_.size(); ++i)
      for (int c = 0; c < 3; ++c) x[3 * i + c] = model_->keypoints(match_[i], c) + u[3 * match_[i] + c];
    return x;
  }

  // Section 2.9 lever rule for a rigid tool (see header).
  double rigidLoadCell(const NodeArray& f) const {
    const double length = tool_.geometry.length_m;
    const double y_clamp = length - tool_.constraints.clamp_length_m;
    const double y_cell = length - tool_.constraints.load_cell_from_top_m;
    double moment = 0;
    for (std::size_t i = 0; i < f.size() / 3; ++i) {
      const double y = received_[3 * i + 1];
      if (y < y_clamp) moment += -f[3 * i + 2] * (y_clamp - y);
    }
    return moment / (y_clamp - y_cell);
  }

  // One cycle of Fig. 3: forces -> FEM step (Eq 9, Eq 10) -> positions -> simulate(dt_FEM).
  void cycle(DriverState& s) {
    if (s.step == insertion_steps_) dem().setRigidMotion(tool_.name, motion(true));
    const auto mode = study_.coupling.force_averaging == study::ForceAveraging::Instantaneous
                          ? adapter::ForceMode::Instantaneous
                          : adapter::ForceMode::IntervalMean;
    const NodeArray forces = dem().nodeForces(tool_.name, mode);
    SensorReadings r;
    const Eigen::VectorXd* u = nullptr;
    if (rigid_) {
      r.load_cell_N = rigidLoadCell(forces);
    } else {
      u = &integrator_->step(toFem(forces));               // Eq (9), reactions by Eq (10)
      dem().setNodePositions(tool_.name, deformedPositions(*u));
      r = sensors_->read(*u, integrator_->reactions());
    }
    dem().simulate(dt_);
    ++s.step;
    last_ = r;
    if (s.step > insertion_steps_) record(s, r, u);
    if (study_.output.vtk_every > 0 && s.step % study_.output.vtk_every == 0) writeVtk(s.step, u);
  }

  void record(DriverState& s, const SensorReadings& r, const Eigen::VectorXd* u) {
    const double t = static_cast<double>(s.step - insertion_steps_) * dt_;
    if (study_.output.csv_every <= 1 || (s.step - insertion_steps_) % study_.output.csv_every == 0) {
      csv_->stream() << number(t) << ',' << number(tool_.motion.velocity_m_s * t * 1e3) << ',' << number(r.load_cell_N)
                     << ',' << number(r.deformation_mm) << ',' << number(r.tip_tilt_deg) << '\n';
      if (u) {
        auto& out = displacements_->stream();
        out.write(reinterpret_cast<const char*>(&t), sizeof t);
        out.write(reinterpret_cast<const char*>(u->data()), static_cast<std::streamsize>(u->size() * sizeof(double)));
      }
    }
    ++s.drag_rows;
    s.force_sum_N += r.load_cell_N;
    s.force_max_N = std::max(s.force_max_N, r.load_cell_N);
  }

  void writeVtk(std::int64_t step, const Eigen::VectorXd* u) const {
    const fs::path dir = options_.output_dir / "vtk";
    fs::create_directories(dir);
    char name[32];
    std::snprintf(name, sizeof name, "tool_%06lld.vtk", static_cast<long long>(step));
    std::ofstream out(dir / name);
    const double t = static_cast<double>(step) * dt_;
    const auto m = motion(step > insertion_steps_);
    const NodeArray local = u ? deformedPositions(*u) : received_;
    out << "# vtk DataFile Version 3.0\ndemfem tool " << tool_.name << " t_s=" << number(t)
        << " (bin frame, m)\nASCII\nDATASET POLYDATA\nPOINTS " << node_count_ << " double\n";
    for (int i = 0; i < node_count_; ++i) {
      for (int c = 0; c < 3; ++c)
        out << number(local[3 * i + c] + m.origin_m[c] + m.velocity_m_s[c] * (t - m.t0_s)) << (c < 2 ? ' ' : '\n');
    }
    out << "POLYGONS " << triangles_.size() << ' ' << 4 * triangles_.size() << '\n';
    for (const auto& tri : triangles_) out << "3 " << tri[0] << ' ' << tri[1] << ' ' << tri[2] << '\n';
    out << "POINT_DATA " << node_count_ << "\nVECTORS displacement_m double\n";
    for (int i = 0; i < node_count_; ++i)
      for (int c = 0; c < 3; ++c) out << number(local[3 * i + c] - received_[3 * i + c]) << (c < 2 ? ' ' : '\n');
    if (!out) throw std::runtime_error("writing VTK file " + (dir / name).string() + " failed");
  }

  void openOutputs(const DriverState& s) {
    const fs::path dir = options_.output_dir;
    if (!options_.resume) {
      std::ofstream kp(dir / "keypoints.csv");
      kp << "id,x_m,y_m,z_m\n";
      for (int k = 0; k < node_count_; ++k) {
        const double* x = rigid_ ? &received_[3 * k] : nullptr;
        kp << k;
        for (int c = 0; c < 3; ++c) kp << ',' << number(rigid_ ? x[c] : model_->keypoints(k, c));
        kp << '\n';
      }
      if (!kp) throw std::runtime_error("writing " + (dir / "keypoints.csv").string() + " failed");
    }
    csv_ = std::make_unique<StagedFile>(dir / "sensors.csv", false);
    csv_->open(options_.resume, s.csv_bytes);
    if (!options_.resume) csv_->stream() << "t_s,displacement_mm,force_N,deformation_mm,tilt_deg\n";
    if (!rigid_) {
      displacements_ = std::make_unique<StagedFile>(dir / "keypoint_displacements.f64", true);
      displacements_->open(options_.resume, s.displacement_bytes);
    }
    writeSidecar(false, "running");
  }

  void closeOutputs(const DriverState& s, const std::string& incomplete) {
    csv_->close(incomplete);
    if (displacements_) displacements_->close(incomplete);
    writeSidecar(incomplete.empty(), incomplete, s.drag_rows);
  }

  void writeSidecar(bool complete, const std::string& reason, std::int64_t rows = 0) const {
    nlohmann::json doc{{"tool", tool_.name},
                       {"depth_mm", tool_.motion.depth_m * 1e3},
                       {"velocity_mm_s", tool_.motion.velocity_m_s * 1e3},
                       {"study", study_.name},
                       {"backend", info_.backend},
                       {"dem_time_step_s", info_.dem_time_step_s},
                       {"fem_time_step_s", dt_},
                       {"rigid_tool", rigid_},
                       {"rows", rows},
                       {"keypoint_count", node_count_},
                       {"keypoint_displacements",
                        rigid_ ? "none (rigid tool)"
                               : "keypoint_displacements.f64: little-endian float64 records [t_s, u_m(3 x keypoint_count, keypoints.csv order)]"},
                       {"complete", complete}};
    if (!complete) doc["incomplete_reason"] = reason;
    const fs::path file = options_.output_dir / "sensors.json";
    std::ofstream(file.string() + ".tmp") << doc.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
    fs::rename(file.string() + ".tmp", file);
  }

  fs::path checkpointDir() const { return options_.output_dir / "checkpoint"; }

  void writeCheckpoint(DriverState& s) {
    fs::create_directories(checkpointDir());
    // The DEM file is named by its step and the FEM file, written last, names it by that step: a
    // kill between the two leaves the previous checkpoint pair intact.
    dem().checkpoint(demCheckpoint(s.step));
    s.csv_bytes = csv_->flushedSize();
    s.displacement_bytes = displacements_ ? displacements_->flushedSize() : 0;
    const fs::path file = checkpointDir() / "fem_state.bin", tmp = file.string() + ".tmp";
    {
      std::ofstream out(tmp, std::ios::binary | std::ios::trunc);
      out.write(kCheckpointMagic, sizeof kCheckpointMagic);
      put(out, s);
      put(out, static_cast<std::uint8_t>(rigid_));
      if (!rigid_) {
        const IntegratorState& st = integrator_->state();
        put(out, st.step);
        for (const auto* v : {&st.u, &st.u_prev, &st.f, &st.f_prev, &st.applied}) writeVector(out, *v);
      }
      put(out, last_);
      if (!out) throw std::runtime_error("writing checkpoint " + tmp.string() + " failed");
    }
    fs::rename(tmp, file);  // the FEM file commits the checkpoint
    // `demfem run` gives the DEM this checkpoint directory; elsewhere there is nothing here to remove.
    if (last_checkpoint_step_ >= 0) fs::remove(checkpointDir() / demCheckpoint(last_checkpoint_step_));
    last_checkpoint_step_ = s.step;
  }

  // A name, not a path: the DEM keeps its checkpoints in its own directory (docs/protocol.md).
  static std::string demCheckpoint(std::int64_t step) { return "dem_" + std::to_string(step) + ".ckpt"; }

  DriverState restoreCheckpoint() {
    const fs::path file = checkpointDir() / "fem_state.bin";
    std::ifstream in(file, std::ios::binary);
    if (!in) throw std::runtime_error("cannot resume: no checkpoint " + file.string());
    char magic[sizeof kCheckpointMagic] = {};
    in.read(magic, sizeof magic);
    if (std::memcmp(magic, kCheckpointMagic, sizeof magic) != 0) throw std::runtime_error(file.string() + " is not a demfem checkpoint");
    const auto s = get<DriverState>(in);
    if (get<std::uint8_t>(in) != static_cast<std::uint8_t>(rigid_))
      throw std::runtime_error(file.string() + ": checkpoint of a " + (rigid_ ? "deformable" : "rigid") + " tool run");
    if (!rigid_) {
      IntegratorState st;
      st.step = get<std::int64_t>(in);
      for (auto* v : {&st.u, &st.u_prev, &st.f, &st.f_prev, &st.applied}) *v = readVector(in, 3 * node_count_);
      integrator_->setState(st);
    }
    last_ = get<SensorReadings>(in);
    if (!in) throw std::runtime_error(file.string() + " is truncated");
    dem().restore(demCheckpoint(s.step));
    t_start_s_ = dem().time() - static_cast<double>(s.step) * dt_;
    last_checkpoint_step_ = s.step;
    dem().setRigidMotion(tool_.name, motion(s.step >= insertion_steps_));
    if (!rigid_) dem().setNodePositions(tool_.name, deformedPositions(integrator_->displacement()));
    return s;
  }

  study::Study study_;
  const study::Tool& tool_;
  adapter::CouplingApi* dem_ = nullptr;
  CoupledRunOptions options_;
  double dt_;
  bool rigid_ = false;
  adapter::BackendInfo info_;
  std::int32_t node_count_ = 0;
  std::vector<std::array<std::int32_t, 3>> triangles_;
  NodeArray received_;       // undeformed node positions as the DEM lists them
  std::vector<int> match_;   // DEM node i -> model keypoint
  std::unique_ptr<ReducedModel> model_;
  std::unique_ptr<ThreeLevelIntegrator> integrator_;
  std::unique_ptr<Sensors> sensors_;
  double clearance_m_ = 0;
  double t_start_s_ = 0;  // DEM time at the start of the insertion
  std::int64_t insertion_steps_ = 0, total_steps_ = 0;
  std::int64_t last_checkpoint_step_ = -1;
  SensorReadings last_;
  std::unique_ptr<StagedFile> csv_, displacements_;
};

CoupledDriver::CoupledDriver(const study::Study& study, CoupledRunOptions options)
    : impl_(std::make_unique<Impl>(study, std::move(options))) {}

CoupledDriver::~CoupledDriver() = default;

CoupledRunSummary CoupledDriver::run(adapter::CouplingApi& dem) { return impl_->run(dem); }

}  // namespace demfem::fem
