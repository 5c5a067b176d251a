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
//   (K_r, M_r + weight) are kept per (study without E, alpha, beta; mass): a change of E scales K_r
//   and every squared natural frequency by the same factor, alpha and beta only change the modal
//   damping (Eq 4 keeps the modes uncoupled), so a re-evaluation is one scalar three-level
//   recursion (Eq 5-10) per mode. Equal to fem::simulateWeightDrop up to the transient of the modes
//   beyond the lowest 40 (static correction keeps the static response exact), except that the record
//   starts 0.1 s earlier, at rest, like a measured one: the weight is hung at t = 0.1 s (a step fit
//   needs the baseline before the step).
// - SoilBinModel (kind coupled or dem-only): one coupled run (fem::CoupledDriver, Fig. 3) against the
//   built-in DEM backend in-process, outputs in a scratch directory, its sensors.csv read back.
#pragma once

#include "demfem/analysis/recording.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <memory>
#include <string>

namespace demfem::campaign {

// The study of `key` derived from `study_json` (see contract), loaded and validated. Throws
// ArgumentError if the study's kind cannot run that kind of case (names the case), study::StudyError
// if the derived study is invalid.
study::Study caseStudy(const nlohmann::ordered_json& study_json, const std::string& origin, const analysis::CaseKey& key);

// The case the study itself describes (its weight or its tool depth), with the study's first tool name.
analysis::CaseKey studyCase(const study::Study& study);

class Model {
 public:
  virtual ~Model() = default;
  // Runs `study` (already derived for `key` by caseStudy()). `scratch` is a directory the model may
  // use for files (created by the caller, removed by the caller). Throws on a failed run.
  virtual analysis::Recording run(const study::Study& study, const analysis::CaseKey& key,
                                  const std::filesystem::path& scratch) = 0;
  // Identifies the model's code path in the run cache (a change of model changes every key).
  virtual std::string name() const = 0;
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

class SoilBinModel final : public Model {
 public:
  analysis::Recording run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path& scratch) override;
  std::string name() const override { return "coupled-builtin-1"; }
};

// The model for the study's kind: weight-drop -> WeightDropModel, coupled / dem-only ->
// SoilBinModel. Throws ArgumentError for other kinds.
std::unique_ptr<Model> makeModel(const study::Study& study);

}  // namespace demfem::campaign
