// demfem analysis: the soil-motion report of one or more runs side by side (paper Section 3.5,
// Fig. 16; docs/analysis.md, "Soil motion"), from the measures of soil_motion.hpp.
//
// Contract
// - analyseRun(): for every requested tool displacement, the particle frame whose toolDisplacement()
//   is nearest (InputError when the run's displacements miss it by more than half the largest step
//   between consecutive frames, or the run has fewer than two frames): the vertical section through the tool's centre
//   (x = mid of its bounds), one horizontal section at half the tool's tip depth, the extent
//   of the region in motion (connectedMovingExtent() above `threshold_m_s` from the particles within
//   `front_reach_m` of the tool's bounds, linked across gaps up to `connect_gap_m`), the speed range in front of the tool (across its width, from its tip up to
//   the surface, from its front face to `front_reach_m` ahead) and the mixing index; the mixing of the
//   first frame (before) and of the last (after the tool passed); on the vertical section's plane and
//   thickness, the flow section in cells of `flow_cell_m`, its alignment order and its streamlines
//   (soil_motion.hpp, flowSection(), alignmentOrder(), traceStreamlines() with `streamlines`). The surface is the highest particle
//   top (y + radius) of the first frame; layer boundaries are layerBoundaries() of the first frame.
//   With `rest_run` the instant's frame is first taken against the rest run's frame at its time
//   (soil_motion.hpp, againstRest(), restFrameAt()): sections, the region in motion, the speeds in
//   front and the flow are then the motion relative to the bed's own rest state.
// - soilMotionJson(): {"threshold_mm_s", "cell_mm", "rest_run" (null without), "runs": [{"run", "tool", "surface_mm",
//   "mixing_before", "mixing_after", "instants": [{"displacement_mm", "t_s", "moving_depth_mm",
//   "moving_length_mm", "moving_width_mm", "moving_particles", "front_speed_min_mm_s",
//   "front_speed_median_mm_s", "front_speed_max_mm_s", "front_particles", "mixing", "streamline_order",
//   "streamline_order_random_baseline", "streamline_order_cells", "streamlines",
//   "mean_streamline_length_mm", "median_streamline_length_mm", "streamline_curvature_rad_per_mm"}]}]}
//   beside "flow_cell_mm", "streamline_step_mm", "streamline_max_step_turn_deg" and
//   "streamline_max_total_turn_deg"; an order without cells and the lengths and curvature without
//   streamlines are null (nothing moves: no value, not zero).
// - writeSoilMotionOutputs() stages soil-motion.json, soil-motion.md (the Markdown section) and, with
//   a renderer, plots/velocity-sections.{svg,png} (vertical sections, one column per run, one row per
//   displacement, the moving region's and the tool's outlines and the streamlines),
//   plots/horizontal-sections.{svg,png}
//   and plots/mixing.{svg,png} (layer-mixing maps before and after), each with its .gp scripts.
#pragma once

#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/soil_motion.hpp"
#include "demfem/analysis/staged_output.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::analysis {

struct SoilMotionSettings {
  std::vector<double> displacements_m;  // tool displacements to look at
  double threshold_m_s = 0.005;         // "in motion"
  double cell_m = 0.01;                 // map cells (one particle diameter of the paper's soil)
  double half_thickness_m = 0.005;      // sections: centres within this of the plane
  double front_reach_m = 0.0105;        // ahead of the front face (one largest diameter)
  double connect_gap_m = 0.001;         // the region in motion: fast spheres at most this apart (a tenth of that diameter)
  double mixing_cell_m = 0.02;
  double flow_cell_m = 0.02;            // flow sections (two diameters: about 5 particles per cell on the section)
  StreamlineRules streamlines;
  std::string tool;                     // empty: the run's only tool
  // A run of the same bed left alone (particle files at the run's times, the same particles in the
  // same order): every measure of an instant takes the velocities against it (againstRest()), so
  // the bed's own creep is not counted as motion. Empty: the velocities as they are.
  std::filesystem::path rest_run;
};

struct SoilMotionInstant {
  double displacement_m = 0, time_s = 0;
  Box tool;
  SectionMap vertical, horizontal;
  MovingExtent extent;
  SpeedRange front;
  double mixing = 0;
  FlowSection flow;
  AlignmentOrder order;
  std::vector<Streamline> streamlines;
  StreamlineStatistics streamline_statistics;
};

struct SoilMotionRun {
  std::string name, tool;
  double surface_y_m = 0;
  std::vector<double> boundaries_y_m;
  double mixing_before = 0, mixing_after = 0;
  SectionMap mixing_map_before, mixing_map_after;
  std::vector<SoilMotionInstant> instants;
};

SoilMotionRun analyseRun(const std::filesystem::path& run_dir, const SoilMotionSettings& settings);

nlohmann::json soilMotionJson(const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& settings);
std::string soilMotionMarkdown(const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& settings);

void writeSoilMotionOutputs(StagedOutput& out, const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& settings,
                            const GnuplotRenderer* renderer);

// The figure of plots/velocity-sections (`vertical`) or plots/horizontal-sections: of each run and
// instant its section map, the outlines of the region in motion (extent.region, when extent.count > 0)
// and of the tool (cut at surface_y_m), and on the vertical sections the streamlines. Reads nothing
// else of a run, so a run rebuilt from kept measures draws the same figure.
Figure sectionsFigure(const std::vector<SoilMotionRun>& runs, bool vertical);

}  // namespace demfem::analysis
