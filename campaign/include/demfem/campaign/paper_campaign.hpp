// demfem campaign STUDY...: the paper's soil-bin cases (Table 1) run one after another or a few at
// a time, each in its own run directory, resumable after an interruption (docs/paper-reproduction.md).
//
// Contract
// - A case is one study file (kind coupled or dem-only, DEM backend builtin); its name is the file's
//   stem, its run directory `directory / name`. Two study files of one stem are an ArgumentError.
// - Run directory: `study.json` (the effective study the case runs, written before it starts),
//   `campaign_case.json` (kRunRecord: wall time summed over every call that ran it, each call's
//   written at every checkpoint and at its end, so a killed call leaves its time up to its last
//   checkpoint, the steps after it being run again; calls; estimate),
//   the coupled run's outputs (fem/coupled_driver.hpp: sensors.csv, sensors.json, ...), the DEM's
//   ParaView files with the FEM's in `vtk/` (output.vtk_every > 0; the study's output.directory is
//   not used), and
//   `checkpoint/` (the FEM state and the built-in DEM's checkpoint of the same step, every
//   `checkpoint_every` FEM steps).
// - Resume: a case whose sensors.json says "complete": true is done and not rerun; one with a
//   checkpoint resumes from it (on the built-in DEM bit for bit the uninterrupted run); otherwise
//   it starts. A run directory whose study.json is another case than the study it would run now
//   (sameCase: any value but dem.threads and the notes differs) is an ArgumentError naming the
//   directory (remove it to start that case over). `max_steps` (a shortened run, e.g. CI) marks
//   the case incomplete, so a later call without it continues it.
// - Soil: every case's settled soil (adapter/settled_soil.hpp) is deposited before any case runs,
//   one deposition per soil hash, in adapter::defaultSoilDirectory() (cases that differ only in
//   depth, velocity or tool share it). A soil that is not settled (adapter::unsettledReason) is an
//   ArgumentError naming the case, the file and the reason before any case runs, unless
//   `allow_unsettled_soil` (the run then records settled: false in its sensors.json).
// - One campaign per directory: runCampaign holds `directory`'s adapter::DirectoryLock for its
//   whole call, so a second call on the same directory throws OutputError naming it and the
//   holder before it reads or writes anything there; each case's run holds its run directory's
//   (fem/coupled_driver.hpp).
// - Concurrency: `jobs` cases at once, each with `threads` built-in DEM threads (0: the study's
//   dem.threads divided by jobs, at least 1); cases start in the given order.
// - Estimates: estimate_wall_s (the caller's estimate from measured speeds, `demfem validate`'s)
//   for each case before it starts; the time left of a case is its estimate until it has run a few
//   steps, then its measured rate; overall: the cases left at the measured-over-estimated ratio of
//   the cases seen so far, divided over `jobs`.
// - Stop: stop_requested() is polled between steps; the running cases end at their last checkpoint
//   (outputs marked incomplete) and runCampaign throws Interrupted (campaign/calibration.hpp).
//   A failed case is reported (state Failed, message) and the others still run.
// - Units: seconds of wall time; steps are FEM steps.
#pragma once

#include "demfem/campaign/model.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace demfem::campaign {

inline constexpr const char* kRunRecord = "campaign_case.json";

enum class CaseState { Pending, Running, Done, Incomplete, Failed };
const char* caseStateName(CaseState state);

struct CaseStatus {
  std::string name;
  std::filesystem::path study_file, run_dir;
  CaseState state = CaseState::Pending;
  bool resumed = false;            // continued from a checkpoint in this call
  bool done_before = false;        // complete before this call: not rerun
  std::int64_t step = 0, total_steps = 0;  // FEM steps done / of the plan (of this call's run)
  double estimate_wall_s = 0;      // before it started
  double wall_s = 0;               // this call
  double eta_s = 0;                // time left
  std::string message;             // failure or incompleteness
};

struct CampaignProgress {
  const std::vector<CaseStatus>* cases = nullptr;  // every case, as of now
  double overall_eta_s = 0;
  double elapsed_s = 0;
};

struct CampaignOptions {
  std::filesystem::path directory = "campaign";
  int jobs = 1;
  int threads = 0;
  std::int64_t checkpoint_every = 200;
  std::optional<std::int64_t> max_steps;
  std::function<double(const study::Study&)> estimate_wall_s;  // may be empty: no estimates (0)
  std::function<void(const CampaignProgress&)> on_progress;     // every 0.2 s, from the calling thread
  // A soil's deposition: the fraction done and, at the end of each settling stage, its summary line
  // (empty otherwise; builtin::DepositProgress).
  DepositionProgress on_deposit;  // study_name: the case name
  bool allow_unsettled_soil = false;
  std::function<bool()> stop_requested;
};

struct CampaignSummary {
  std::vector<CaseStatus> cases;
  double wall_s = 0;
  bool complete() const;  // every case Done
};

// Runs the cases (see contract). Throws ArgumentError for bad arguments or a foreign run
// directory, study::StudyError for an invalid study file, Interrupted on a stop request.
CampaignSummary runCampaign(const std::vector<std::filesystem::path>& study_files, const CampaignOptions& options);

nlohmann::json toJson(const CampaignSummary& summary);

// The text of a case's study as its run directory keeps it (study.json): the study without
// dem.threads, which may differ between an interrupted call and the one that resumes it.
std::string caseStudyRecord(const study::Study& study);

// What makes two versions of a study the same case: its study::identityJson() without dem.threads
// and the free-text `notes`, compact. A note edited after a run, or a key added later at the default
// that gives the earlier numbers, neither makes that run "of another study" nor stales its kept
// evaluation; any value that changes the numbers does.
std::string caseIdentity(const study::Study& study);
bool sameCase(const study::Study& a, const study::Study& b);

// A run directory whose sensors.json says "complete": true (a damaged one is not finished).
bool finishedRun(const std::filesystem::path& run_dir);

}  // namespace demfem::campaign
