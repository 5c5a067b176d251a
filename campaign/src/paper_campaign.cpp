// The cases of `demfem campaign` (campaign/paper_campaign.hpp): run directories, resume, soil,
// concurrency and the time left.
#include "demfem/campaign/paper_campaign.hpp"

#include "demfem/adapter/forwarding_api.hpp"

#include "demfem/adapter/output_files.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/parameters.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/fem/reduction_cache.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <fstream>
#include <mutex>
#include <set>
#include <thread>

namespace demfem::campaign {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

namespace {

// The built-in DEM in process, its checkpoints kept in the run's checkpoint directory: the FEM
// driver names them ("dem_STEP.ckpt") and removes the previous one there (fem/coupled_driver.hpp),
// as a DEM server started with --checkpoint-dir does.
class CheckpointsInDirectory final : public adapter::ForwardingApi {
 public:
  CheckpointsInDirectory(std::unique_ptr<adapter::CouplingApi> dem, fs::path dir)
      : ForwardingApi(*dem), dem_(std::move(dem)), dir_(std::move(dir)) {}
  void checkpoint(const fs::path& file) override { inner().checkpoint(dir_ / file.filename()); }
  void restore(const fs::path& file) override { inner().restore(dir_ / file.filename()); }

 private:
  std::unique_ptr<adapter::CouplingApi> dem_;
  fs::path dir_;
};

// Adds `wall_s` to the case's record (kRunRecord), counting a call when `new_call`: the record
// sums the time of every call that ran the case, each up to its last checkpoint (a call killed after
// it leaves that much, its later steps are run again) or its end.
void recordWallTime(const fs::path& run_dir, double wall_s, double estimate_s, bool new_call) {
  const fs::path file = run_dir / kRunRecord;
  nlohmann::json doc = nlohmann::json::object();
  if (std::ifstream in(file); in) {
    try {
      doc = nlohmann::json::parse(in);
    } catch (const nlohmann::json::exception& e) {
      throw std::runtime_error(file.string() + ": " + e.what());
    }
  }
  doc["wall_time_s"] = doc.value("wall_time_s", 0.0) + wall_s;
  doc["calls"] = doc.value("calls", 0) + (new_call ? 1 : 0);
  doc["estimated_wall_time_s"] = estimate_s;
  adapter::writeFileAtomically(file, doc.dump(2) + '\n');
}

struct Case {
  CaseStatus status;
  study::Study study;
  Clock::time_point started;
  Clock::time_point recorded;  // this call's time is in the run record up to here
  bool call_recorded = false;  // this call is counted in the record's calls
};

// Claims the run directory for the study (see contract) and says whether it resumes.
bool prepareRunDirectory(const Case& c) {
  const fs::path record = c.status.run_dir / "study.json";
  if (fs::exists(record)) {
    if (!sameCase(study::loadStudy(record), c.study))
      throw ArgumentError(c.status.run_dir.string() + " holds a run of another study than " + c.status.study_file.string() +
                          " (its study.json differs); remove that directory to start the case over");
    return fs::exists(c.status.run_dir / "checkpoint" / "fem_state.bin");
  }
  fs::create_directories(c.status.run_dir);
  adapter::writeFileAtomically(record, caseStudyRecord(c.study));
  return false;
}

void depositSoils(const std::vector<Case>& cases, const CampaignOptions& o) {
  std::set<std::string> done;
  for (const Case& c : cases) {
    if (c.status.state == CaseState::Done || !done.insert(study::soilHash(c.study)).second) continue;
    const fs::path file = adapter::settledSoilFile(c.study, adapter::defaultSoilDirectory());
    if (!fs::exists(file))
      builtin::ensureSettledSoil(c.study, [&](double fraction, const std::string& stage_line) {
        if (o.on_deposit) o.on_deposit(c.status.name, fraction, stage_line);
      });
    const std::string message = adapter::unsettledSoilMessage(file, adapter::readSettledSoil(file, c.study).settling);
    if (!message.empty() && !o.allow_unsettled_soil) throw ArgumentError("case " + c.status.name + " (no case was run): " + message);
  }
}

class Runner {
 public:
  Runner(std::vector<Case>& cases, const CampaignOptions& o) : cases_(cases), o_(o), start_(Clock::now()) {}

  void runAll() {
    std::vector<std::thread> workers;
    for (int j = 0; j < std::max(1, o_.jobs); ++j) workers.emplace_back([this] { work(); });
    while (finished_ < static_cast<int>(workers.size())) {
      report();
      std::this_thread::sleep_for(std::chrono::milliseconds(200));
    }
    for (auto& w : workers) w.join();
    report();
  }

  bool interrupted() const { return interrupted_; }

 private:
  void work() {
    for (;;) {
      const std::size_t i = next_++;
      if (i >= cases_.size() || stopping()) break;
      runCase(cases_[i]);
    }
    ++finished_;
  }

  bool stopping() {
    if (o_.stop_requested && o_.stop_requested()) interrupted_ = true;
    return interrupted_;
  }

  void runCase(Case& c) {
    if (c.status.state == CaseState::Done) return;
    fem::CoupledRunOptions run;
    run.output_dir = c.status.run_dir;
    run.reduction_cache_dir = fem::defaultReductionDirectory();
    run.checkpoint_every = o_.checkpoint_every;
    run.max_steps = o_.max_steps;
    run.stop_requested = [this] { return stopping(); };
    run.on_progress = [this, &c](const fem::CoupledProgress& p) {
      const std::lock_guard lock(mutex_);
      c.status.step = p.step;
      c.status.total_steps = p.total_steps;
      c.status.eta_s = p.eta_s;
      c.status.wall_s = std::chrono::duration<double>(Clock::now() - c.started).count();
      if (p.step % o_.checkpoint_every == 0) recordCall(c);  // a checkpoint was just written
    };
    run.resume = c.status.resumed;
    {
      const std::lock_guard lock(mutex_);
      c.status.state = CaseState::Running;
      c.started = c.recorded = Clock::now();
      c.call_recorded = false;
    }
    try {
      study::Study run_study = c.study;
      run_study.output.directory = c.status.run_dir;  // the DEM's particle and tool files beside the FEM's, in the run directory
      fem::CoupledDriver driver(run_study, run);
      CheckpointsInDirectory dem(builtin::makeBackend(run_study), c.status.run_dir / "checkpoint");
      const fem::CoupledRunSummary s = driver.run(dem);
      const std::lock_guard lock(mutex_);
      c.status.state = s.complete ? CaseState::Done : CaseState::Incomplete;
      c.status.message = s.incomplete_reason;
      c.status.eta_s = 0;
    } catch (const fem::CoupledRunInterrupted& e) {
      const std::lock_guard lock(mutex_);
      c.status.state = CaseState::Incomplete;
      c.status.message = e.what();
    } catch (const std::exception& e) {
      const std::lock_guard lock(mutex_);
      c.status.state = CaseState::Failed;
      c.status.message = e.what();
    }
    const std::lock_guard lock(mutex_);
    c.status.wall_s = std::chrono::duration<double>(Clock::now() - c.started).count();
    try {
      recordCall(c);
    } catch (const std::exception& e) {
      c.status.state = CaseState::Failed;
      c.status.message = e.what();
    }
  }

  // Adds this call's time since the last record to the case's run record. Called with mutex_ held.
  static void recordCall(Case& c) {
    const Clock::time_point now = Clock::now();
    recordWallTime(c.status.run_dir, std::chrono::duration<double>(now - c.recorded).count(), c.status.estimate_wall_s, !c.call_recorded);
    c.recorded = now;
    c.call_recorded = true;
  }

  // Time left overall: running cases at their own rate, the pending ones at their estimate scaled
  // by measured / estimated of the cases that have run long enough to say.
  double overallEta() const {
    double measured = 0, estimated = 0, running = 0, pending = 0;
    for (const Case& c : cases_) {
      const CaseStatus& s = c.status;
      if (s.state == CaseState::Running && s.step > 0 && s.total_steps > 0) {
        measured += s.wall_s + s.eta_s;
        estimated += s.estimate_wall_s;
        running += s.eta_s;
      } else if (s.state == CaseState::Pending) {
        pending += s.estimate_wall_s;
      }
    }
    const double ratio = estimated > 0 ? measured / estimated : 1.0;
    return (running + ratio * pending) / std::max(1, o_.jobs);
  }

  void report() {
    if (!o_.on_progress) return;
    const std::lock_guard lock(mutex_);
    std::vector<CaseStatus> snapshot;
    for (const Case& c : cases_) snapshot.push_back(c.status);
    for (CaseStatus& s : snapshot)
      if (s.state == CaseState::Running && s.step == 0) s.eta_s = s.estimate_wall_s;
    CampaignProgress p;
    p.cases = &snapshot;
    p.overall_eta_s = overallEta();
    p.elapsed_s = std::chrono::duration<double>(Clock::now() - start_).count();
    o_.on_progress(p);
  }

  std::vector<Case>& cases_;
  const CampaignOptions& o_;
  Clock::time_point start_;
  std::mutex mutex_;
  std::atomic<std::size_t> next_{0};
  std::atomic<int> finished_{0};
  std::atomic<bool> interrupted_{false};
};

std::vector<Case> loadCases(const std::vector<fs::path>& files, const CampaignOptions& o) {
  std::vector<Case> cases;
  std::set<std::string> names;
  for (const fs::path& file : files) {
    Case c;
    c.status.study_file = file;
    c.status.name = file.stem().string();
    if (!names.insert(c.status.name).second)
      throw ArgumentError("two study files named '" + c.status.name + "': each case needs its own run directory (" +
                          (o.directory / c.status.name).string() + ")");
    c.study = study::loadStudy(file);
    if (c.study.kind != study::StudyKind::Coupled && c.study.kind != study::StudyKind::DemOnly)
      throw ArgumentError(file.string() + ": a campaign case is a coupled or dem-only study");
    if (c.study.dem.backend != "builtin")
      throw ArgumentError(file.string() + ": /dem/backend is '" + c.study.dem.backend + "'; campaign cases run on the built-in DEM");
    const int threads = o.threads > 0 ? o.threads : std::max(1, c.study.dem.threads / std::max(1, o.jobs));
    c.study.dem.threads = threads;
    c.status.run_dir = o.directory / c.status.name;
    c.status.estimate_wall_s = o.estimate_wall_s ? o.estimate_wall_s(c.study) : 0;
    if (finishedRun(c.status.run_dir)) {
      if (!sameCase(study::loadStudy(c.status.run_dir / "study.json"), c.study))
        throw ArgumentError(c.status.run_dir.string() + " holds a finished run of another study than " + file.string() +
                            "; remove that directory to run the case again");
      c.status.state = CaseState::Done;
      c.status.done_before = true;
    }
    cases.push_back(std::move(c));
  }
  return cases;
}

}  // namespace

namespace {

// The study as a case records it: without dem.threads, which does not change a run's numbers.
nlohmann::ordered_json caseRecordJson(const study::Study& s) {
  nlohmann::ordered_json doc = study::toJson(s);
  if (doc.contains("dem")) doc["dem"].erase("threads");
  return doc;
}

}  // namespace

std::string caseStudyRecord(const study::Study& s) { return caseRecordJson(s).dump(2) + '\n'; }

std::string caseIdentity(const study::Study& s) {
  nlohmann::ordered_json doc = study::identityJson(s);
  if (doc.contains("dem")) doc["dem"].erase("threads");
  doc.erase("notes");
  return doc.dump();
}

bool sameCase(const study::Study& a, const study::Study& b) { return caseIdentity(a) == caseIdentity(b); }

bool finishedRun(const fs::path& run_dir) {
  std::ifstream in(run_dir / "sensors.json");
  if (!in) return false;
  try {
    return nlohmann::json::parse(in).value("complete", false);
  } catch (const nlohmann::json::exception&) {
    return false;  // a damaged sidecar is a run to redo, not a finished one
  }
}

const char* caseStateName(CaseState state) {
  switch (state) {
    case CaseState::Pending: return "pending";
    case CaseState::Running: return "running";
    case CaseState::Done: return "done";
    case CaseState::Incomplete: return "incomplete";
    case CaseState::Failed: return "failed";
  }
  return "unknown";
}

bool CampaignSummary::complete() const {
  return std::all_of(cases.begin(), cases.end(), [](const CaseStatus& c) { return c.state == CaseState::Done; });
}

CampaignSummary runCampaign(const std::vector<fs::path>& study_files, const CampaignOptions& options) {
  if (study_files.empty()) throw ArgumentError("no study files given");
  if (options.jobs < 1) throw ArgumentError("--jobs must be at least 1");
  if (options.checkpoint_every < 1) throw ArgumentError("--checkpoint-every must be at least 1");
  const adapter::DirectoryLock lock(options.directory);  // before any run directory is read
  const auto start = Clock::now();
  std::vector<Case> cases = loadCases(study_files, options);
  for (Case& c : cases)
    if (c.status.state != CaseState::Done) c.status.resumed = prepareRunDirectory(c);
  depositSoils(cases, options);
  Runner runner(cases, options);
  runner.runAll();
  CampaignSummary summary;
  for (const Case& c : cases) summary.cases.push_back(c.status);
  summary.wall_s = std::chrono::duration<double>(Clock::now() - start).count();
  if (runner.interrupted()) throw Interrupted("campaign interrupted; run the same command again to resume from the checkpoints");
  return summary;
}

nlohmann::json toJson(const CampaignSummary& summary) {
  nlohmann::json cases = nlohmann::json::array();
  for (const CaseStatus& c : summary.cases)
    cases.push_back({{"name", c.name},
                     {"study", c.study_file.string()},
                     {"run_dir", c.run_dir.string()},
                     {"state", caseStateName(c.state)},
                     {"resumed", c.resumed},
                     {"done_before", c.done_before},
                     {"steps", c.step},
                     {"total_steps", c.total_steps},
                     {"estimated_wall_time_s", c.estimate_wall_s},
                     {"wall_time_s", c.wall_s},
                     {"message", c.message}});
  return {{"complete", summary.complete()}, {"wall_time_s", summary.wall_s}, {"cases", cases}};
}

}  // namespace demfem::campaign
