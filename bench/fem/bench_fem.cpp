// FEM client benchmark: keypoint count, reduced size, set-up time (assembly + keypoint
// substructuring) and time per FEM step (Eq 9 + Eq 10) for the paper's tools (Section 2.9,
// Table 3). Prints a table; --json writes the same numbers.
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/integrator.hpp"
#include "demfem/fem/model.hpp"

#include <chrono>
#include <ctime>
#include <cstdio>

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point start) { return std::chrono::duration<double>(Clock::now() - start).count(); }

// Processor time of this process (s): on a shared machine it shows the cost without the waiting.
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

demfem::study::Tool paperTool(const std::string& name) {
  demfem::study::Tool t;
  t.name = name;
  t.geometry.length_m = 0.200;
  t.geometry.width_m = 0.040;
  t.fem.alpha_s = 0.55e-3;
  if (name == "PMMA") {
    t.geometry.thickness_m = 0.004;
    t.fem.youngs_Pa = 4.06e9, t.fem.poisson = 0.38, t.fem.density_kg_m3 = 1220;
  } else {
    t.geometry.thickness_m = 0.003;
    t.fem.youngs_Pa = 2.07e11, t.fem.poisson = 0.3, t.fem.density_kg_m3 = 7933;
  }
  return t;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-fem: set-up and step cost of the FEM client for the paper's tools"};
  app.name("demfem-bench-fem");
  std::string tool_name = "PMMA";
  int steps = 200;
  double spacing_mm = 5;
  app.add_option("--tool", tool_name, "PMMA (200x40x4 mm) or S235 (200x40x3 mm)")->check(CLI::IsMember({"PMMA", "S235"}));
  app.add_option("--steps", steps, "FEM steps to time")->check(CLI::PositiveNumber);
  app.add_option("--spacing-mm", spacing_mm, "keypoint grid spacing (mm)")->check(CLI::PositiveNumber);
  std::string& json_target = demfem::cli::addJsonOption(app);
  app.callback([&] {
    using namespace demfem::fem;
    demfem::study::Tool tool = paperTool(tool_name);
    tool.geometry.keypoint_spacing_m = spacing_mm * 1e-3;
    const double dt = 1e-3;  // Table 3 dt_FEM

    auto t0 = Clock::now();
    double c0 = cpuSeconds();
    const FullModel full = buildPlateModel(tool);
    const double assembly_s = secondsSince(t0), assembly_cpu_s = cpuSeconds() - c0;
    t0 = Clock::now(), c0 = cpuSeconds();
    const ReducedModel reduced = reduce(full);
    const double reduction_s = secondsSince(t0), reduction_cpu_s = cpuSeconds() - c0;
    t0 = Clock::now(), c0 = cpuSeconds();
    ThreeLevelIntegrator integrator(reduced, dt, {tool.fem.alpha_s, tool.fem.beta_per_s});
    const double integrator_setup_s = secondsSince(t0), integrator_setup_cpu_s = cpuSeconds() - c0;
    Eigen::VectorXd f = Eigen::VectorXd::Zero(reduced.dofCount());
    for (int k = 0; k < reduced.keypointCount(); ++k)
      if (reduced.keypoints(k, 2) > 0) f(3 * k + 2) = -1.0 / reduced.keypointCount();
    t0 = Clock::now(), c0 = cpuSeconds();
    for (int i = 0; i < steps; ++i) integrator.step(f);
    const double step_s = secondsSince(t0) / steps, step_cpu_s = (cpuSeconds() - c0) / steps;

    std::printf("%-34s %12s %12s\n", "quantity", tool_name.c_str(), "cpu");
    std::printf("%-34s %12zu\n", "mesh nodes", full.mesh.nodes.size());
    std::printf("%-34s %12d\n", "full DOFs", full.dofCount());
    std::printf("%-34s %12d\n", "keypoints", reduced.keypointCount());
    std::printf("%-34s %12d\n", "reduced DOFs", reduced.dofCount());
    std::printf("%-34s %12zu\n", "free reduced DOFs", reduced.freeDofs().size());
    std::printf("%-34s %12.3f %12.3f\n", "mesh + assembly (s)", assembly_s, assembly_cpu_s);
    std::printf("%-34s %12.3f %12.3f\n", "substructuring Eq 11-15 (s)", reduction_s, reduction_cpu_s);
    std::printf("%-34s %12.3f %12.3f\n", "integrator set-up, A1 factor (s)", integrator_setup_s, integrator_setup_cpu_s);
    std::printf("%-34s %12.3f %12.3f\n", "time per FEM step (ms)", step_s * 1e3, step_cpu_s * 1e3);
    demfem::cli::writeJson(json_target, {{"tool", tool_name},
                                         {"keypoint_spacing_mm", spacing_mm},
                                         {"mesh_nodes", full.mesh.nodes.size()},
                                         {"full_dofs", full.dofCount()},
                                         {"keypoints", reduced.keypointCount()},
                                         {"reduced_dofs", reduced.dofCount()},
                                         {"assembly_s", assembly_s},
                                         {"assembly_cpu_s", assembly_cpu_s},
                                         {"substructuring_s", reduction_s},
                                         {"substructuring_cpu_s", reduction_cpu_s},
                                         {"integrator_setup_s", integrator_setup_s},
                                         {"integrator_setup_cpu_s", integrator_setup_cpu_s},
                                         {"step_ms", step_s * 1e3},
                                         {"step_cpu_ms", step_cpu_s * 1e3},
                                         {"steps_timed", steps}});
  });
  return demfem::cli::runApp(app, argc, argv);
}
