#include "demfem/fem/coupled_driver.hpp"

#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/output_files.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "demfem/fem/modal.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/reduction_cache.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/study/tool_motion.hpp"
#include "demfem/vtkio/vtk_files.hpp"

#include <nlohmann/json.hpp>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <memory>
#include <sstream>

namespace demfem::fem {

namespace fs = std::filesystem;
using adapter::CheckedFile;
using adapter::NodeArray;

namespace {

constexpr char kCheckpointMagic[] = "demfem-coupled-fem-state-4";
constexpr char kFemStateKind[] = "fem-state";  // the checkpoint container's kind of fem_state.bin

std::string number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.17g", v);
  return text;
}

std::string_view bytesOf(const double* data, std::size_t count) {
  return {reinterpret_cast<const char*>(data), count * sizeof(double)};
}

// One output stream written as NAME.partial and renamed to NAME when the run ends.
class StagedFile {
 public:
  StagedFile(fs::path final_path, bool binary, bool resume, std::uint64_t resume_size)
      : final_(std::move(final_path)), binary_(binary) {
    const fs::path partial = partialPath();
    if (resume && !fs::exists(partial)) {
      if (!fs::exists(final_)) throw std::runtime_error("cannot resume: " + partial.string() + " is missing");
      adapter::renameChecked(final_, partial);
    }
    out_ = std::make_unique<CheckedFile>(partial, resume ? CheckedFile::Mode::Append : CheckedFile::Mode::Truncate,
                                         resume ? resume_size : 0);
  }
  CheckedFile& out() { return *out_; }
  // Trailer (text files, when incomplete), sync, close, rename. Throws OutputError; the file then
  // keeps its .partial name.
  void close(const std::string& incomplete_reason) {
    if (!out_->isOpen()) return;
    if (!incomplete_reason.empty() && !binary_) out_->write("# incomplete: " + incomplete_reason + "\n");
    out_->close();
    adapter::renameChecked(partialPath(), final_);
  }

 private:
  fs::path partialPath() const { return final_.string() + ".partial"; }
  fs::path final_;
  bool binary_;
  std::unique_ptr<CheckedFile> out_;
};

void writeVector(std::ostream& out, const Eigen::VectorXd& v) {
  const std::uint64_t n = static_cast<std::uint64_t>(v.size());
  out.write(reinterpret_cast<const char*>(&n), sizeof n);
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(n * sizeof(double)));
}

// A vector written by writeVector; its size is checked by the integrator that restores it.
Eigen::VectorXd readVector(std::istream& in) {
  constexpr std::uint64_t kMaxEntries = std::uint64_t{1} << 32;
  std::uint64_t n = 0;
  in.read(reinterpret_cast<char*>(&n), sizeof n);
  if (!in || n > kMaxEntries) throw std::runtime_error("checkpoint vector size is not readable");
  Eigen::VectorXd v(static_cast<Eigen::Index>(n));
  in.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(double)));
  return v;
}

template <class T> void put(std::ostream& out, const T& v) { out.write(reinterpret_cast<const char*>(&v), sizeof v); }
template <class T> T get(std::istream& in) {
  T v{};
  in.read(reinterpret_cast<char*>(&v), sizeof v);
  return v;
}

// What the driver carries between steps besides the integrator (checkpointed with it).
struct DriverState {
  std::int64_t step = 0;
  std::int64_t drag_rows = 0;
  double plan_start_s = 0;  // DEM clock at plan time 0 (the start of the insertion)
  double force_sum_N = 0;
  double force_max_N = -std::numeric_limits<double>::infinity();
  std::uint64_t csv_bytes = 0, displacement_bytes = 0;
};

}  // namespace

struct CoupledDriver::Impl {
  Impl(const study::Study& study, CoupledRunOptions options)
      : study_(study), tool_(firstTool(study_)), options_(std::move(options)), dt_(study.fem.dt_s),
        plan_(study::planToolMotion(study_, tool_)) {
    rigid_ = study_.kind == study::StudyKind::DemOnly || !tool_.fem.deformable;
    buildFem();
    run_steps_ = plan_.totalSteps();
    if (options_.max_steps) run_steps_ = std::min(run_steps_, *options_.max_steps);
  }

  // Connects the FEM model to the DEM's geometry (keypoint matching), once per run.
  void attach() {
    info_ = dem().info();
    findGeometry();
    received_ = dem().nodePositions(tool_.name);
    if (received_.size() != 3 * static_cast<std::size_t>(node_count_))
      throw std::invalid_argument("DEM geometry '" + tool_.name + "' lists " + std::to_string(node_count_) +
                                  " nodes but sent " + std::to_string(received_.size() / 3) + " positions");
    match_ = matchKeypoints(*model_, received_, options_.keypoint_tolerance_m);
  }

  adapter::CouplingApi& dem() const { return *dem_; }

  CoupledRunSummary run(adapter::CouplingApi& dem_api) {
    const adapter::DirectoryLock lock(options_.output_dir);  // before anything is read or written there
    dem_ = &dem_api;
    attach();
    DriverState state;
    const auto wall_start = std::chrono::steady_clock::now();
    try {
      if (options_.resume) state = restoreCheckpoint();
      openOutputs(state);
      if (!options_.resume) start(state);
      forces_ = dem().nodeForces(tool_.name, forceMode());  // of the last interval: the first cycle's load
      const std::int64_t first_step = state.step;
      while (state.step < run_steps_) {
        if (options_.stop_requested && options_.stop_requested())
          throw CoupledRunInterrupted("interrupted by a stop request at step " + std::to_string(state.step));
        cycle(state);
        if (options_.checkpoint_every > 0 && state.step % options_.checkpoint_every == 0 && state.step < run_steps_)
          writeCheckpoint(state);
        if (options_.on_progress) {
          const double wall = secondsSince(wall_start);
          const double rate = wall > 0 ? static_cast<double>(state.step - first_step) / wall : 0;
          options_.on_progress({state.step, run_steps_, static_cast<double>(state.step) * dt_,
                                static_cast<double>(run_steps_) * dt_, rate,
                                rate > 0 ? static_cast<double>(run_steps_ - state.step) / rate : 0});
        }
      }
    } catch (const std::exception& e) {
      const std::string unmarked = closeOutputs(state, e.what());
      if (!unmarked.empty())
        throw std::runtime_error(std::string(e.what()) + "; the outputs could not all be marked incomplete: " + unmarked);
      throw;
    }
    CoupledRunSummary summary;
    summary.planned_steps = plan_.totalSteps();
    if (state.step < summary.planned_steps)
      summary.incomplete_reason = "stopped after " + std::to_string(state.step) + " of " +
                                  std::to_string(summary.planned_steps) + " FEM steps";
    summary.complete = summary.incomplete_reason.empty();
    if (const std::string unmarked = closeOutputs(state, summary.incomplete_reason); !unmarked.empty())
      throw adapter::OutputError("the run ended but its outputs could not be closed: " + unmarked);
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
    const FullModel full = buildFullModel(tool_);
    model_ = std::make_unique<ReducedModel>(options_.reduction_cache_dir
                                                ? reduceCached(full, *options_.reduction_cache_dir, options_.on_reduction_progress)
                                                : reduce(full, options_.on_reduction_progress));
    if (rigid_) {
      load_cell_influence_ = loadCellInfluence(*model_);
      return;
    }
    std::function<ModalBasis()> modal_basis;  // computed by the integrator unless cached
    if (options_.reduction_cache_dir)
      modal_basis = [&] { return modalBasisCached(full, *model_, dt_, *options_.reduction_cache_dir); };
    integrator_ = makeIntegrator(*model_, dt_, RayleighDamping{tool_.fem.alpha_s, tool_.fem.beta_per_s}, study_.fem.integration, modal_basis);
    sensors_ = std::make_unique<Sensors>(*model_, tool_);
  }

  adapter::RigidMotion motionOfStep(std::int64_t step, double plan_start_s) const {
    return adapter::rigidMotionOf(plan_.phaseOfStep(step), plan_start_s);
  }

  void start(DriverState& s) {
    // The DEM clock need not start at 0 (a settled soil, a restart): plan time 0 is now on it.
    s.plan_start_s = dem().time();
    dem().setRigidMotion(tool_.name, motionOfStep(0, s.plan_start_s));
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

  adapter::ForceMode forceMode() const {
    return study_.coupling.force_averaging == study::ForceAveraging::Instantaneous ? adapter::ForceMode::Instantaneous
                                                                                   : adapter::ForceMode::IntervalMean;
  }

  // One cycle of Fig. 3: forces -> FEM step (Eq 9, Eq 10) -> positions -> simulate(dt_FEM) -> the
  // interval's forces, the last three in one exchange (advance), with the step's outputs written
  // meanwhile (overlapped with a remote DEM's interval).
  void cycle(DriverState& s) {
    if (s.step == plan_.insertion_steps) dem().setRigidMotion(tool_.name, motionOfStep(s.step, s.plan_start_s));
    SensorReadings r;
    const Eigen::VectorXd* u = nullptr;
    NodeArray positions;  // empty: a rigid tool's nodes stay where they are
    if (rigid_) {
      r.load_cell_N = load_cell_influence_.dot(toFem(forces_));
    } else {
      u = &integrator_->step(toFem(forces_));  // Eq (9), reactions by Eq (10)
      positions = deformedPositions(*u);
      r = sensors_->read(*u, integrator_->reactions());
    }
    const bool vtk = study_.output.vtk_every > 0 && s.step % study_.output.vtk_every == 0;
    const double vtk_time_s = vtk ? dem().time() : 0.0;
    const std::int64_t drag_step = s.step + 1 - plan_.insertion_steps;  // of the state the interval reaches
    NodeArray next = dem().advance(tool_.name, positions, dt_, forceMode(), [&] {
      if (vtk) writeVtk(s, vtk_time_s, rigid_ ? received_ : positions, forces_);
      if (drag_step > 0) record(s, drag_step, r, u);
    });
    forces_ = std::move(next);
    ++s.step;
    last_ = r;
  }

  // The sensors of drag step `drag_step` (the state `drag_step` FEM steps after the insertion).
  void record(DriverState& s, std::int64_t drag_step, const SensorReadings& r, const Eigen::VectorXd* u) {
    const double t = static_cast<double>(drag_step) * dt_;
    if (study_.output.csv_every <= 1 || drag_step % study_.output.csv_every == 0) {
      csv_->out().write(number(t) + ',' + number(tool_.motion.velocity_m_s * t * 1e3) + ',' + number(r.load_cell_N) + ',' +
                        number(r.deformation_mm) + ',' + number(r.tip_tilt_deg) + '\n');
      if (u) {
        displacements_->out().write(bytesOf(&t, 1));
        displacements_->out().write(bytesOf(u->data(), static_cast<std::size_t>(u->size())));
      }
    }
    ++s.drag_rows;
    s.force_sum_N += r.load_cell_N;
    s.force_max_N = std::max(s.force_max_N, r.load_cell_N);
  }

  fs::path vtkDirectory() const { return options_.output_dir / "vtk"; }

  // The tool as the DEM simulates it from now on (node positions `local` in its frame, those of this
  // step's advance), at the DEM's time `t`, named by the FEM step that begins now: a .vtu (vtkio)
  // with node displacement_m and the node force_N applied.
  void writeVtk(const DriverState& s, double t, const NodeArray& local, const NodeArray& forces) {
    const auto m = motionOfStep(s.step, s.plan_start_s);
    vtkio::Dataset d;
    d.time_s = t;
    vtkio::PointArray displacement{"displacement_m", 3, {}, vtkio::ValueType::Float64};
    for (int i = 0; i < node_count_; ++i)
      for (int c = 0; c < 3; ++c) {
        d.points.push_back(local[3 * i + c] + m.origin_m[c] + m.velocity_m_s[c] * (t - m.t0_s));
        displacement.values.push_back(local[3 * i + c] - received_[3 * i + c]);
      }
    for (const auto& tri : triangles_) d.triangles.push_back({tri[0], tri[1], tri[2]});
    d.arrays = {displacement, {"force_N", 3, forces, vtkio::ValueType::Float64}};
    char name[24];
    std::snprintf(name, sizeof name, "_%06lld.vtu", static_cast<long long>(s.step));
    const std::string file = "fem-" + tool_.name + name;
    adapter::writeFileAtomically(vtkDirectory() / file, vtkio::encode(d, vtkio::Format::UnstructuredGrid), adapter::Durability::Unsynced);
    vtk_series_->add(t, file);
  }

  void openOutputs(const DriverState& s) {
    const fs::path dir = options_.output_dir;
    writeSidecar(s, "running");
    if (!options_.resume) {
      std::string kp = "id,x_m,y_m,z_m\n";
      for (int k = 0; k < node_count_; ++k) {
        kp += std::to_string(k);
        for (int c = 0; c < 3; ++c) kp += ',' + number(model_->keypoints(k, c));
        kp += '\n';
      }
      adapter::writeFileAtomically(dir / "keypoints.csv", kp);
    }
    csv_ = std::make_unique<StagedFile>(dir / "sensors.csv", false, options_.resume, s.csv_bytes);
    if (!options_.resume) csv_->out().write("t_s,displacement_mm,force_N,deformation_mm,tilt_deg\n");
    if (!rigid_)
      displacements_ = std::make_unique<StagedFile>(dir / "keypoint_displacements.f64", true, options_.resume, s.displacement_bytes);
    if (study_.output.vtk_every > 0) {
      fs::create_directories(vtkDirectory());
      const std::optional<double> resume_time = options_.resume ? std::optional<double>(dem().time()) : std::nullopt;
      vtk_series_ = std::make_unique<adapter::VtkSeries>(vtkDirectory() / ("fem-" + tool_.name + ".pvd"), resume_time);
    }
  }

  // Ends every output (trailer, final name, sidecar); `reason` non-empty marks them incomplete.
  // Returns what could not be written (empty when everything was).
  std::string closeOutputs(const DriverState& s, const std::string& reason) {
    std::string failed;
    const auto attempt = [&failed](const std::function<void()>& f) {
      try {
        f();
      } catch (const std::exception& e) {
        failed += (failed.empty() ? "" : "; ") + std::string(e.what());
      }
    };
    for (StagedFile* f : {csv_.get(), displacements_.get()})
      if (f) attempt([&] { f->close(reason); });
    attempt([&] { writeSidecar(s, reason); });
    return failed;
  }

  // `reason` empty: complete; "running" while the run goes on; otherwise why it is incomplete.
  void writeSidecar(const DriverState& s, const std::string& reason) const {
    nlohmann::json doc{{"tool", tool_.name},
                       {"depth_mm", tool_.motion.depth_m * 1e3},
                       {"velocity_mm_s", tool_.motion.velocity_m_s * 1e3},
                       {"study", study_.name},
                       {"backend", info_.backend},
                       {"dem_time_step_s", info_.dem_time_step_s},
                       {"fem_time_step_s", dt_},
                       {"rigid_tool", rigid_},
                       {"rows", s.drag_rows},
                       {"steps", s.step},
                       {"planned_steps", plan_.totalSteps()},
                       {"insertion_steps", plan_.insertion_steps},
                       {"keypoint_count", node_count_},
                       {"keypoint_displacements",
                        rigid_ ? "none (rigid tool)"
                               : "keypoint_displacements.f64: little-endian float64 records [t_s, u_m(3 x keypoint_count, keypoints.csv order)]"},
                       {"complete", reason.empty()}};
    if (!reason.empty()) doc["incomplete_reason"] = reason;
    if (!info_.soil_json.empty()) doc["soil"] = nlohmann::json::parse(info_.soil_json);  // the DEM's settled soil
    adapter::writeFileAtomically(options_.output_dir / "sensors.json",
                                 doc.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + '\n');
  }

  fs::path checkpointDir() const { return options_.output_dir / "checkpoint"; }

  void writeCheckpoint(DriverState& s) {
    fs::create_directories(checkpointDir());
    // The DEM file is named by its step and the FEM file, written last, names it by that step: a
    // kill between the two leaves the previous checkpoint pair intact.
    dem().checkpoint(demCheckpoint(s.step));
    for (StagedFile* f : {csv_.get(), displacements_.get()})
      if (f) f->out().sync();
    s.csv_bytes = csv_->out().size();
    s.displacement_bytes = displacements_ ? displacements_->out().size() : 0;
    std::ostringstream out(std::ios::binary);
    out.write(kCheckpointMagic, sizeof kCheckpointMagic);
    put(out, s);
    put(out, static_cast<std::uint8_t>(rigid_));
    if (!rigid_) {
      const SavedIntegratorState st = integrator_->save();
      put(out, st.step);
      put(out, static_cast<std::uint64_t>(st.vectors.size()));
      for (const Eigen::VectorXd& v : st.vectors) writeVector(out, v);
    }
    put(out, last_);
    // The checkpoint container (size and checksum, adapter/checkpoint_file.hpp); writing it commits the checkpoint.
    adapter::writeCheckpointFile(checkpointDir() / "fem_state.bin", kFemStateKind, out.str());
    // `demfem run` gives the DEM this checkpoint directory; elsewhere there is nothing here to remove.
    if (last_checkpoint_step_ >= 0) fs::remove(checkpointDir() / demCheckpoint(last_checkpoint_step_));
    last_checkpoint_step_ = s.step;
  }

  // A name, not a path: the DEM keeps its checkpoints in its own directory (docs/protocol.md).
  static std::string demCheckpoint(std::int64_t step) { return "dem_" + std::to_string(step) + ".ckpt"; }

  DriverState restoreCheckpoint() {
    const fs::path file = checkpointDir() / "fem_state.bin";
    if (!fs::exists(file)) throw std::runtime_error("cannot resume: no checkpoint " + file.string());
    std::istringstream in(adapter::readCheckpointFile(file, kFemStateKind, "cannot resume: FEM checkpoint"), std::ios::binary);
    char magic[sizeof kCheckpointMagic] = {};
    in.read(magic, sizeof magic);
    if (std::memcmp(magic, kCheckpointMagic, sizeof magic) != 0)
      throw std::runtime_error(file.string() + " is not a checkpoint of this demfem version");
    const auto s = get<DriverState>(in);
    if (get<std::uint8_t>(in) != static_cast<std::uint8_t>(rigid_))
      throw std::runtime_error(file.string() + ": checkpoint of a " + (rigid_ ? "deformable" : "rigid") + " tool run");
    if (!rigid_) {
      SavedIntegratorState st;
      st.step = get<std::int64_t>(in);
      const auto count = get<std::uint64_t>(in);
      for (std::uint64_t i = 0; in && i < count && i < 64; ++i) st.vectors.push_back(readVector(in));
      if (!in) throw std::runtime_error(file.string() + " is truncated");
      try {
        integrator_->restore(st);
      } catch (const std::invalid_argument& e) {
        throw std::runtime_error(file.string() + ": " + e.what());
      }
    }
    last_ = get<SensorReadings>(in);
    if (!in) throw std::runtime_error(file.string() + " is truncated");
    if (in.peek() != std::char_traits<char>::eof()) throw std::runtime_error(file.string() + ": bytes left over after the FEM state");
    // The DEM's checkpoint holds the tool's motion, node positions and their velocity: nothing is
    // re-sent (a re-sent position would reset the deformation velocity, a recomputed motion its t0).
    dem().restore(demCheckpoint(s.step));
    last_checkpoint_step_ = s.step;
    return s;
  }

  study::Study study_;
  const study::Tool& tool_;
  adapter::CouplingApi* dem_ = nullptr;
  CoupledRunOptions options_;
  double dt_;
  study::ToolMotionPlan plan_;
  std::int64_t run_steps_ = 0;  // plan_.totalSteps(), or max_steps if fewer
  bool rigid_ = false;
  adapter::BackendInfo info_;
  std::int32_t node_count_ = 0;
  std::vector<std::array<std::int32_t, 3>> triangles_;
  NodeArray received_;       // undeformed node positions as the DEM lists them
  std::vector<int> match_;   // DEM node i -> model keypoint
  std::unique_ptr<ReducedModel> model_;
  std::unique_ptr<TimeIntegrator> integrator_;
  std::unique_ptr<Sensors> sensors_;
  Eigen::VectorXd load_cell_influence_;  // rigid tool: load_cell_N = c . f (model order)
  std::int64_t last_checkpoint_step_ = -1;
  SensorReadings last_;
  NodeArray forces_;  // the particles' forces on the tool over the last DEM interval (DEM node order)
  std::unique_ptr<StagedFile> csv_, displacements_;
  std::unique_ptr<adapter::VtkSeries> vtk_series_;
};

CoupledDriver::CoupledDriver(const study::Study& study, CoupledRunOptions options)
    : impl_(std::make_unique<Impl>(study, std::move(options))) {}

CoupledDriver::~CoupledDriver() = default;

CoupledRunSummary CoupledDriver::run(adapter::CouplingApi& dem) { return impl_->run(dem); }

}  // namespace demfem::fem
