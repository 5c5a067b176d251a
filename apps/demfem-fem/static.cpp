// demfem-fem static: a tip or distributed load against travel on a study's tool (Eq 2 on the
// reduced model): deflection, sensors and reactions.
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"

#include <cstdio>

namespace demfem::cli {

void addFemStaticCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("static", "Static tip or distributed load against travel: deflection, sensors and reactions");
  auto study_file = std::make_shared<std::string>();
  auto tool_name = std::make_shared<std::string>();
  auto tip_load = std::make_shared<double>(0);
  auto distributed_load = std::make_shared<double>(0);
  cmd->add_option("study", *study_file, "study file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--tool", *tool_name, "tool name (default: the first deformable tool)");
  auto* tip = cmd->add_option("--tip-load-N", *tip_load, "total load (N) against travel on the tip keypoint row");
  auto* spread = cmd->add_option("--distributed-load-N", *distributed_load,
                                 "total load (N) against travel spread evenly over the front-face keypoints below the clamp");
  tip->excludes(spread);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([=, &json_target] {
    if (*tip_load == 0 && *distributed_load == 0) throw InputError("static: give --tip-load-N or --distributed-load-N (non-zero)");
    const study::Study study = study::loadStudy(*study_file);
    const study::Tool& tool = fem::deformableTool(study, *tool_name);
    const fem::ReducedModel model = fem::reduce(fem::buildFullModel(tool));
    const double tip_y = model.keypoints.col(1).minCoeff(), front_z = model.keypoints.col(2).maxCoeff();
    const double clamp_edge = model.keypoints.col(1).maxCoeff() - tool.constraints.clamp_length_m;
    std::vector<int> loaded, tip_row;
    for (int k = 0; k < model.keypointCount(); ++k) {
      const bool on_tip = model.keypoints(k, 1) <= tip_y + 1e-9;
      if (on_tip) tip_row.push_back(k);
      if (*tip_load != 0 ? on_tip : (model.keypoints(k, 2) >= front_z - 1e-9 && model.keypoints(k, 1) < clamp_edge - 1e-9))
        loaded.push_back(k);
    }
    const double total = *tip_load != 0 ? *tip_load : *distributed_load;
    Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
    for (int k : loaded) f(3 * k + 2) = -total / static_cast<double>(loaded.size());
    const fem::StaticSolution s = fem::solveStatic(model, f);
    const fem::SensorReadings reading = fem::Sensors(model, tool).read(s.displacement, s.reaction);
    double tip_deflection = 0;
    for (int k : tip_row) tip_deflection -= s.displacement(3 * k + 2) / static_cast<double>(tip_row.size());
    Eigen::Vector3d total_reaction = Eigen::Vector3d::Zero();
    for (int k = 0; k < model.keypointCount(); ++k) total_reaction += s.reaction.segment<3>(3 * k);
    std::printf("tool %s, %s load %.6g N against travel on %zu keypoints\n", tool.name.c_str(),
                *tip_load != 0 ? "tip" : "distributed", total, loaded.size());
    std::printf("tip deflection        %12.6f mm\n", 1000 * tip_deflection);
    std::printf("sensor deformation    %12.6f mm\n", reading.deformation_mm);
    std::printf("tip tilt              %12.6f deg\n", reading.tip_tilt_deg);
    std::printf("load-cell force       %12.6f N\n", reading.load_cell_N);
    std::printf("clamp force z         %12.6f N\n", total_reaction.z() - reading.load_cell_N);
    std::printf("total reaction z      %12.6f N\n", total_reaction.z());
    writeJson(json_target, {{"study", study.name},
                            {"tool", tool.name},
                            {"load", *tip_load != 0 ? "tip" : "distributed"},
                            {"load_N", total},
                            {"loaded_keypoints", loaded.size()},
                            {"tip_deflection_mm", 1000 * tip_deflection},
                            {"deformation_mm", reading.deformation_mm},
                            {"tip_tilt_deg", reading.tip_tilt_deg},
                            {"load_cell_N", reading.load_cell_N},
                            {"clamp_reaction_z_N", total_reaction.z() - reading.load_cell_N},
                            {"total_reaction_N", {total_reaction.x(), total_reaction.y(), total_reaction.z()}}});
  });
}

}  // namespace demfem::cli
