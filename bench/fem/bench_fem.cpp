// FEM client benchmark: keypoint count, reduced size, set-up time (assembly + keypoint
// substructuring) and time per FEM step (Eq 9 + Eq 10) for the paper's tools (Section 2.9,
// Table 3), of the full three-level integration and of the modal one (fem/modal.hpp), timed in
// interleaved rounds (full, modal, full, modal, ...) under the same soil-like load: the front-face
// keypoints of the lowest --depth-mm carry forces that change every step. Prints a table; --json
// writes the same numbers.
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/integrator.hpp"
#include "demfem/fem/modal.hpp"
#include "demfem/fem/model.hpp"

#include <algorithm>
#include <chrono>
#include <ctime>
#include <cstdio>
#include <random>

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

// Soil-like keypoint forces (N): every front-face keypoint within depth_m of the tip in contact in
// 60 % of the steps, each force fluctuating from step to step around 0.5 N against travel.
std::vector<Eigen::VectorXd> soilLikeLoads(const demfem::fem::ReducedModel& model, double depth_m, int steps) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<Eigen::VectorXd> loads;
  for (int i = 0; i < steps; ++i) {
    Eigen::VectorXd f = Eigen::VectorXd::Zero(model.dofCount());
    for (int k = 0; k < model.keypointCount(); ++k)
      if (model.keypoints(k, 1) <= depth_m + 1e-9 && model.keypoints(k, 2) > 0 && unit(rng) < 0.6) {
        f(3 * k + 2) = -0.5 * (0.5 + unit(rng));
        f(3 * k + 1) = 0.1 * (unit(rng) - 0.5);
      }
    loads.push_back(f);
  }
  return loads;
}

struct StepCost {
  double wall_ms = 0, cpu_ms = 0;
};

// The median over rounds of each integrator's time per step, rounds interleaved.
std::pair<StepCost, StepCost> interleavedStepCost(demfem::fem::TimeIntegrator& full, demfem::fem::TimeIntegrator& modal,
                                                  const std::vector<Eigen::VectorXd>& loads, int rounds) {
  std::vector<double> wall[2], cpu[2];
  demfem::fem::TimeIntegrator* integrators[2] = {&full, &modal};
  for (int r = 0; r < rounds; ++r)
    for (int which = 0; which < 2; ++which) {
      integrators[which]->start(loads.front());
      const auto t0 = Clock::now();
      const double c0 = cpuSeconds();
      for (const auto& f : loads) integrators[which]->step(f);
      wall[which].push_back(secondsSince(t0) * 1e3 / static_cast<double>(loads.size()));
      cpu[which].push_back((cpuSeconds() - c0) * 1e3 / static_cast<double>(loads.size()));
    }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  return {{median(wall[0]), median(cpu[0])}, {median(wall[1]), median(cpu[1])}};
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
  int rounds = 5;
  double depth_mm = 18;
  app.add_option("--rounds", rounds, "interleaved timing rounds (full, modal) of --steps each")->check(CLI::PositiveNumber);
  app.add_option("--depth-mm", depth_mm, "loaded depth from the tip (mm; the quick study's 18)")->check(CLI::PositiveNumber);
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
    t0 = Clock::now(), c0 = cpuSeconds();
    ModalIntegrator modal(reduced, dt, {tool.fem.alpha_s, tool.fem.beta_per_s});
    const double modal_setup_s = secondsSince(t0), modal_setup_cpu_s = cpuSeconds() - c0;
    const auto loads = soilLikeLoads(reduced, depth_mm * 1e-3, steps);
    const auto [full_step, modal_step] = interleavedStepCost(integrator, modal, loads, rounds);

    std::FILE* const table = demfem::cli::textStream(json_target);
    std::fprintf(table, "%-34s %12s %12s\n", "quantity", tool_name.c_str(), "cpu");
    std::fprintf(table, "%-34s %12zu\n", "mesh nodes", full.mesh.nodes.size());
    std::fprintf(table, "%-34s %12d\n", "full DOFs", full.dofCount());
    std::fprintf(table, "%-34s %12d\n", "keypoints", reduced.keypointCount());
    std::fprintf(table, "%-34s %12d\n", "reduced DOFs", reduced.dofCount());
    std::fprintf(table, "%-34s %12zu\n", "free reduced DOFs", reduced.freeDofs().size());
    std::fprintf(table, "%-34s %12.3f %12.3f\n", "mesh + assembly (s)", assembly_s, assembly_cpu_s);
    std::fprintf(table, "%-34s %12.3f %12.3f\n", "substructuring Eq 11-15 (s)", reduction_s, reduction_cpu_s);
    std::fprintf(table, "%-34s %12.3f %12.3f\n", "integrator set-up, A1 factor (s)", integrator_setup_s, integrator_setup_cpu_s);
    std::fprintf(table, "%-34s %12.3f %12.3f\n", "modal set-up, modes + R (s)", modal_setup_s, modal_setup_cpu_s);
    std::fprintf(table, "%-34s %12d\n", "modes integrated (w dt <= 30)", modal.modeCount());
    std::fprintf(table, "%-34s %12.1f\n", "highest mode integrated (Hz)", modal.highestModeHz());
    std::fprintf(table, "%-34s %12.4f %12.4f\n", "full step, median (ms)", full_step.wall_ms, full_step.cpu_ms);
    std::fprintf(table, "%-34s %12.4f %12.4f\n", "modal step, median (ms)", modal_step.wall_ms, modal_step.cpu_ms);
    std::fprintf(table, "%-34s %12.1f %12.1f\n", "full / modal", full_step.wall_ms / modal_step.wall_ms, full_step.cpu_ms / modal_step.cpu_ms);
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
                                         {"modal_setup_s", modal_setup_s},
                                         {"modal_setup_cpu_s", modal_setup_cpu_s},
                                         {"modes", modal.modeCount()},
                                         {"highest_mode_Hz", modal.highestModeHz()},
                                         {"loaded_depth_mm", depth_mm},
                                         {"full_step_ms", full_step.wall_ms},
                                         {"full_step_cpu_ms", full_step.cpu_ms},
                                         {"modal_step_ms", modal_step.wall_ms},
                                         {"modal_step_cpu_ms", modal_step.cpu_ms},
                                         {"steps_per_round", steps},
                                         {"rounds", rounds}});
  });
  return demfem::cli::runApp(app, argc, argv);
}
