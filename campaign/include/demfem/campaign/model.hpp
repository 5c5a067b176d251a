// demfem campaign: the model a calibration reruns, one case at a time (docs/calibration.md).
//
// Contract
// - A Model turns (study file JSON, case) into a calibrated-format recording (analysis/recording.hpp:
//   t_s, force_N, deformation_mm, and displacement_mm for soil-bin cases), exactly what the normal
//   commands would write for that study, so analysis::evaluate() treats measured and simulated data
//   alike.
// - The study is the model of ONE case; the case's own key sets the rest: a calibration-weight case
//   sets /weight_drop/mass_kg, a soil-bin case sets /tools/0/motion/depth_mm (caseStudy()).
// - run() is safe to call from several threads at once on one Model (concurrent cases).
// - WeightDropModel (study kind weight-drop): fem::simulateWeightDrop's physics (Section 2.10.1,
//   Eq 3-10) computed in the reduced model's modal basis. The reduction and the eigenvectors of
//   (K_r, M_r + weight) are kept per (study without E, alpha, beta, sensor gains and the clamp
//   spring's value; mass): a change of E scales K_r and every squared natural frequency by the same
//   factor, alpha and beta only change the modal damping (Eq 4 keeps the modes uncoupled), gains
//   scale the outputs, so a re-evaluation is one scalar three-level recursion (Eq 5-10) per mode; a
//   clamp spring's value (and E with a spring) is set on the kept reduction exactly and costs one
//   eigen solution per value. Equal to fem::simulateWeightDrop up to the transient of the modes
//   beyond the lowest 40 (static correction keeps the static response exact), except that the record
//   starts 0.1 s earlier, at rest, like a measured one: the weight is hung at t = 0.1 s (a step fit
//   needs the baseline before the step).
// - SoilBinModel (kind coupled or dem-only) against the built-in DEM backend in-process, with the
//   force of SoilForce:
//   The DEM's files (output.vtk_every > 0) go to the run's scratch directory too, never to the
//   study's output.directory, which concurrent runs of one study would share.
//   * LoadCell: one coupled run (fem::CoupledDriver, Fig. 3), outputs in a scratch directory, its
//     sensors.csv read back (force_N = the load cell; a rigid tool's static split of the soil forces);
//   * Draught: a rigid tool only (kind dem-only or fem.deformable false): the DEM alone drives the
//     tool's motion plan (adapter::insertAndStartDrag, then one simulate() per FEM step of the drag),
//     no FEM model; force_N = the draught, minus the sum of the z node forces (N, the soil's force
//     against the travel), mean over each FEM step; deformation_mm = 0; t_s at the end of each step
//     from the start of the drag, displacement_mm = velocity x t_s. This is the total force a
//     soil-bin DEM simulation reports (docs/calibration.md, "Soil against LIGGGHTS").
//   prepare() makes each case soil's settled-soil file (adapter/settled_soil.hpp, in
//   adapter::defaultSoilDirectory()) once, before the cases of one evaluation run concurrently: one
//   deposition serves every depth of one soil (the depth is not part of the soil hash). Packing:
//   * per soil (no packing study): the case study's own deposition (friction enters the packing, so
//     every new friction value is a new deposition);
//   * shared (a packing study, normally the study the command was given): the case soil's file
//     holds the particles of the packing study's deposition at the case's seed, each tagged with
//     the case study's layer at its depth (builtin::layerAt): one deposition per seed for a whole
//     calibration, and every parameter value drags through the same packing (common random
//     numbers: the objective's noise between neighbouring values is the drag's, not another
//     packing's). The packing study's soil hash is part of name(). Bin, fill height and particle
//     sizes must be the packing study's (ArgumentError otherwise).
//   A soil that is not settled (adapter::unsettledReason) is an ArgumentError naming the study, the
//   file and the reason, unless `allow_unsettled_soil`.
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace demfem::campaign {

// The study of `key` derived from `study_json` (see contract), loaded and validated. With
// `stroke_end_mm`, a soil-bin case's stroke is cut to it when the study's is longer (the run then
// ends where the objective's window ends). Throws ArgumentError if the study's kind cannot run that
// kind of case (names the case), study::StudyError if the derived study is invalid.
study::Study caseStudy(const nlohmann::ordered_json& study_json, const std::string& origin, const analysis::CaseKey& key,
                       std::optional<double> stroke_end_mm = std::nullopt);

// The case the study itself describes (its weight or its tool depth), with the study's first tool name.
analysis::CaseKey studyCase(const study::Study& study);

// Progress of a deposition a model makes: the study whose soil it deposits, the fraction done, and
// the deposition's stage line (a settling report; empty between them).
using DepositionProgress = std::function<void(const std::string& study_name, double fraction, const std::string& stage_line)>;

class Model {
 public:
  virtual ~Model() = default;
  // Runs `study` (already derived for `key` by caseStudy()). `scratch` is a directory the model may
  // use for files (created by the caller, removed by the caller). Throws on a failed run.
  virtual analysis::Recording run(const study::Study& study, const analysis::CaseKey& key,
                                  const std::filesystem::path& scratch) = 0;
  // Identifies the model's code path in the run cache (a change of model changes every key).
  virtual std::string name() const = 0;
  // Called once per evaluation with the studies of the cases about to run (possibly concurrently):
  // work they share is done here, once, its depositions reported through `on_deposit` (may be
  // empty). Throws on failure. Default: nothing.
  virtual void prepare(const std::vector<study::Study>& case_studies, const DepositionProgress& on_deposit) {
    (void)case_studies, (void)on_deposit;
  }
};

class WeightDropModel final : public Model {
 public:
  WeightDropModel();
  ~WeightDropModel() override;
  analysis::Recording run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path& scratch) override;
  std::string name() const override { return "weight-drop-modal-1"; }
  int basesBuilt() const;  // reductions + eigen decompositions done so far (for the benchmark)

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// What a soil-bin model records as force_N (see contract).
enum class SoilForce { LoadCell, Draught };

class SoilBinModel final : public Model {
 public:
  explicit SoilBinModel(SoilForce force = SoilForce::LoadCell, std::optional<study::Study> packing = std::nullopt,
                        bool allow_unsettled_soil = false)
      : force_(force), packing_(std::move(packing)), allow_unsettled_soil_(allow_unsettled_soil) {}
  // Throws ArgumentError for SoilForce::Draught with a deformable tool.
  analysis::Recording run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path& scratch) override;
  std::string name() const override;
  void prepare(const std::vector<study::Study>& case_studies, const DepositionProgress& on_deposit) override;

 private:
  void prepareSoil(const study::Study& study, const DepositionProgress& on_deposit) const;
  // Writes `file`: the packing study's deposition at the study's seed, relabelled (see contract).
  void relabelPacking(const study::Study& study, const std::filesystem::path& file, const DepositionProgress& on_deposit) const;
  SoilForce force_;
  std::optional<study::Study> packing_;
  bool allow_unsettled_soil_ = false;
};

// The model for the study's kind: weight-drop -> WeightDropModel, coupled / dem-only ->
// SoilBinModel with `soil_force`, its packing shared from `study` when `shared_packing`, refusing an
// unsettled soil unless `allow_unsettled_soil`. Throws ArgumentError for other kinds.
std::unique_ptr<Model> makeModel(const study::Study& study, SoilForce soil_force = SoilForce::LoadCell, bool shared_packing = false,
                                 bool allow_unsettled_soil = false);

}  // namespace demfem::campaign
