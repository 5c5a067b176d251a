#include "demfem/analysis/soil_motion_report.hpp"

#include "demfem/analysis/recording.hpp"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

namespace demfem::analysis {

namespace {

using nlohmann::json;

double surfaceOf(const ParticleFrame& f) {
  double top = -INFINITY;
  for (std::size_t i = 0; i < f.size(); ++i) top = std::max(top, f.position_m[3 * i + 1] + f.radius_m[i]);
  return top;
}

// The frame whose tool displacement is nearest `target`; InputError beyond half the frame spacing.
std::size_t frameAt(const RunFrames& run, double target) {
  std::size_t best = 0;
  for (std::size_t k = 1; k < run.time_s.size(); ++k)
    if (std::fabs(toolDisplacement(run, k) - target) < std::fabs(toolDisplacement(run, best) - target)) best = k;
  double spacing = 0;  // the largest step between consecutive frames (the insertion's frames do not move in z)
  for (std::size_t k = 1; k < run.time_s.size(); ++k)
    spacing = std::max(spacing, std::fabs(toolDisplacement(run, k) - toolDisplacement(run, k - 1)));
  if (std::fabs(toolDisplacement(run, best) - target) > 0.5 * spacing + 1e-9)
    throw InputError(run.directory.string() + ": no particle file near a tool displacement of " + std::to_string(target * 1e3) +
                     " mm (the frames reach " + std::to_string(toolDisplacement(run, run.time_s.size() - 1) * 1e3) + " mm)");
  return best;
}

SoilMotionInstant instantOf(const RunFrames& run, std::size_t k, const ParticleFrame& frame, const SoilMotionRun& r,
                            const SoilMotionSettings& s) {
  SoilMotionInstant in;
  in.displacement_m = toolDisplacement(run, k);
  in.time_s = run.time_s[k];
  in.tool = run.tool_frames[k].bounds();
  const double mid_x = 0.5 * (in.tool.lo[0] + in.tool.hi[0]);
  in.vertical = velocitySection(frame, Axis::X, mid_x, s.half_thickness_m, s.cell_m);
  in.horizontal = velocitySection(frame, Axis::Y, 0.5 * (r.surface_y_m + in.tool.lo[1]), s.half_thickness_m, s.cell_m);
  Box near_tool = in.tool;  // the particles touching the tool: its bounds grown by one largest diameter
  for (int c = 0; c < 3; ++c) near_tool.lo[c] -= s.front_reach_m, near_tool.hi[c] += s.front_reach_m;
  in.extent = connectedMovingExtent(frame, s.threshold_m_s, r.surface_y_m, near_tool, s.connect_gap_m);
  const Box front{{in.tool.lo[0], in.tool.lo[1], in.tool.hi[2]}, {in.tool.hi[0], r.surface_y_m, in.tool.hi[2] + s.front_reach_m}};
  in.front = frontVelocityRange(frame, front);
  in.mixing = mixingIndex(frame, s.mixing_cell_m, r.boundaries_y_m);
  in.flow = flowSection(frame, Axis::X, mid_x, s.half_thickness_m, s.flow_cell_m, s.threshold_m_s);
  in.order = alignmentOrder(in.flow);
  in.streamlines = traceStreamlines(in.flow, s.streamlines);
  in.streamline_statistics = streamlineStatistics(in.streamlines);
  return in;
}

// A rectangle (u, v) as a closed line.
Series outline(const std::string& title, double u0, double u1, double v0, double v1, const char* color) {
  return {title, {u0, u1, u1, u0, u0}, {v0, v0, v1, v1, v0}, color, SeriesStyle::Line, 2.0, {}};
}

MapPanel mapPanel(const SectionMap& m, const std::string& title, const std::string& v_label, const std::string& value_label,
                  double value_scale) {
  MapPanel p;
  p.title = title;
  p.x_label = "z along the bin (mm)";
  p.y_label = v_label;
  p.value_label = value_label;
  p.x0 = m.u0_m * 1e3;
  p.dx = m.cell_m * 1e3;
  p.y0 = m.v0_m * 1e3;
  p.dy = m.cell_m * 1e3;
  p.nx = m.nu;
  p.ny = m.nv;
  for (const double v : m.values) p.values.push_back(v * value_scale);
  return p;
}

std::vector<double> millimetres(const std::vector<double>& metres) {
  std::vector<double> out;
  for (const double m : metres) out.push_back(m * 1e3);
  return out;
}

// A value in mm (or mm-based units) for JSON: null when it is not defined (NaN).
json jsonMm(double metres) { return std::isfinite(metres) ? json(metres * 1e3) : json(nullptr); }
json jsonValue(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

double degrees(double radians) { return radians * 180 / M_PI; }

std::string mm(double metres) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(1) << metres * 1e3;
  return out.str();
}

Figure mixingFigure(const std::vector<SoilMotionRun>& runs) {
  Figure f;
  f.title = "Layer mixing (label entropy per cell / entropy of all labels)";
  f.columns = static_cast<int>(runs.size());
  for (const bool after : {false, true})
    for (const auto& r : runs)
      f.panels.push_back(mapPanel(after ? r.mixing_map_after : r.mixing_map_before, r.name + (after ? ": after" : ": before"), "y up (mm)",
                                  "mixing", 1.0));
  f.row_height_px = 300;
  f.width_px = 640 * static_cast<int>(std::max<std::size_t>(1, runs.size()));
  return f;
}

// The streamline-order part of the Markdown section: the rules, then one row per run and instant.
void streamlineTable(std::ostream& md, const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& s) {
  md << "\nStreamline order on the vertical section through the tool (Fig. 16c: organised, long streamlines against short, "
        "irregular ones), in cells of "
     << mm(s.flow_cell_m) << " mm: alignment = length of the mean unit velocity vector of the moving particles of a cell, weighted by "
        "them (1 organised; independent random directions give about 1/sqrt(n), the baseline); streamlines through every cell in motion "
        "(RK2, steps of "
     << mm(s.streamlines.step_fraction * s.flow_cell_m) << " mm, ended on leaving the region, below the threshold, at a turn above "
     << degrees(s.streamlines.max_step_turn_rad) << " degrees per step or after " << degrees(s.streamlines.max_total_turn_rad)
     << " degrees in all).\n\n"
        "| run | displacement (mm) | alignment order (random baseline, cells) | streamlines | mean length (mm) | median length (mm) | "
        "curvature (rad/mm) |\n|---|---|---|---|---|---|---|\n";
  for (const auto& r : runs)
    for (const auto& in : r.instants) {
      const auto& st = in.streamline_statistics;
      md << "| " << r.name << " | " << mm(in.displacement_m) << " | ";
      if (in.order.cells)
        md << std::setprecision(3) << in.order.order << " (" << in.order.random_baseline << ", " << in.order.cells << ")";
      else
        md << "none (no cell with 2 moving particles)";
      if (st.count)
        md << " | " << st.count << " | " << mm(st.mean_length_m) << " | " << mm(st.median_length_m) << " | " << std::setprecision(3)
           << st.curvature_rad_per_m * 1e-3 << " |\n";
      else
        md << " | none (nothing in motion) | | | |\n";
    }
}

}  // namespace

Figure sectionsFigure(const std::vector<SoilMotionRun>& runs, bool vertical) {
  Figure f;
  f.title = vertical ? "Particle speed on the vertical section through the tool (Fig. 16)" : "Particle speed on a horizontal section at half the tool depth";
  f.columns = static_cast<int>(runs.size());
  std::size_t rows = 0;
  for (const auto& r : runs) rows = std::max(rows, r.instants.size());
  for (std::size_t i = 0; i < rows; ++i)
    for (const auto& r : runs) {
      if (i >= r.instants.size()) {
        f.panels.push_back(XYPanel{r.name + ": no frame", "", "", false, false, {}, "top left"});
        continue;
      }
      const auto& in = r.instants[i];
      const std::string title = r.name + " at " + mm(in.displacement_m) + " mm";
      MapPanel p = mapPanel(vertical ? in.vertical : in.horizontal, title, vertical ? "y up (mm)" : "x across the bin (mm)", "speed (mm/s)", 1e3);
      const int v = vertical ? 1 : 0;
      if (in.extent.count)
        p.overlays.push_back(outline("moving > threshold", in.extent.region.lo[2] * 1e3, in.extent.region.hi[2] * 1e3,
                                     in.extent.region.lo[v] * 1e3, in.extent.region.hi[v] * 1e3, "#000000"));
      if (vertical)
        for (std::size_t l = 0; l < in.streamlines.size(); ++l)
          p.overlays.push_back({l == 0 ? "streamlines" : "", millimetres(in.streamlines[l].u_m), millimetres(in.streamlines[l].v_m), "#303030",
                                SeriesStyle::Line, 0.8, {}});
      p.overlays.push_back(outline("tool", in.tool.lo[2] * 1e3, in.tool.hi[2] * 1e3, in.tool.lo[v] * 1e3,
                                   std::min(in.tool.hi[v], vertical ? r.surface_y_m : in.tool.hi[v]) * 1e3, "#ffffff"));
      f.panels.push_back(p);
    }
  f.row_height_px = 300;
  f.width_px = 640 * static_cast<int>(std::max<std::size_t>(1, runs.size()));
  return f;
}

SoilMotionRun analyseRun(const std::filesystem::path& run_dir, const SoilMotionSettings& s) {
  const RunFrames run = loadRun(run_dir, s.tool);
  if (run.time_s.size() < 2) throw InputError(run_dir.string() + ": needs at least two particle files");
  SoilMotionRun r;
  r.name = run_dir.filename().empty() ? run_dir.parent_path().filename().string() : run_dir.filename().string();
  r.tool = run.tool;
  const ParticleFrame first = readParticleFrame(run.particle_files.front());
  r.surface_y_m = surfaceOf(first);
  r.boundaries_y_m = layerBoundaries(first);
  r.mixing_before = mixingIndex(first, s.mixing_cell_m, r.boundaries_y_m);
  r.mixing_map_before = mixingSection(first, s.mixing_cell_m);
  const ParticleFrame last = readParticleFrame(run.particle_files.back());
  r.mixing_after = mixingIndex(last, s.mixing_cell_m, r.boundaries_y_m);
  r.mixing_map_after = mixingSection(last, s.mixing_cell_m);
  for (const double d : s.displacements_m) {
    const std::size_t k = frameAt(run, d);
    ParticleFrame frame = readParticleFrame(run.particle_files[k]);
    if (!s.rest_run.empty()) {
      const auto rest_file = restFrameAt(s.rest_run, run.time_s[k]);
      frame = againstRest(frame, readParticleFrame(rest_file), rest_file);
    }
    r.instants.push_back(instantOf(run, k, frame, r, s));
  }
  return r;
}

json soilMotionJson(const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& s) {
  json out{{"threshold_mm_s", s.threshold_m_s * 1e3}, {"cell_mm", s.cell_m * 1e3}, {"mixing_cell_mm", s.mixing_cell_m * 1e3},
           {"flow_cell_mm", s.flow_cell_m * 1e3}, {"streamline_step_mm", s.streamlines.step_fraction * s.flow_cell_m * 1e3},
           {"streamline_max_step_turn_deg", degrees(s.streamlines.max_step_turn_rad)},
           {"streamline_max_total_turn_deg", degrees(s.streamlines.max_total_turn_rad)},
           {"rest_run", s.rest_run.empty() ? json(nullptr) : json(s.rest_run.string())}, {"runs", json::array()}};
  for (const auto& r : runs) {
    json run{{"run", r.name}, {"tool", r.tool}, {"surface_mm", r.surface_y_m * 1e3}, {"mixing_before", r.mixing_before},
             {"mixing_after", r.mixing_after}, {"instants", json::array()}};
    for (const auto& in : r.instants)
      run["instants"].push_back({{"displacement_mm", in.displacement_m * 1e3},
                                 {"t_s", in.time_s},
                                 {"moving_depth_mm", in.extent.depth_m * 1e3},
                                 {"moving_length_mm", in.extent.length_m * 1e3},
                                 {"moving_width_mm", in.extent.width_m * 1e3},
                                 {"moving_particles", in.extent.count},
                                 {"front_speed_min_mm_s", in.front.min_m_s * 1e3},
                                 {"front_speed_median_mm_s", in.front.median_m_s * 1e3},
                                 {"front_speed_max_mm_s", in.front.max_m_s * 1e3},
                                 {"front_particles", in.front.count},
                                 {"mixing", in.mixing},
                                 {"streamline_order", jsonValue(in.order.order)},
                                 {"streamline_order_random_baseline", jsonValue(in.order.random_baseline)},
                                 {"streamline_order_cells", in.order.cells},
                                 {"streamlines", in.streamline_statistics.count},
                                 {"mean_streamline_length_mm", jsonMm(in.streamline_statistics.mean_length_m)},
                                 {"median_streamline_length_mm", jsonMm(in.streamline_statistics.median_length_m)},
                                 {"streamline_curvature_rad_per_mm", jsonValue(in.streamline_statistics.curvature_rad_per_m * 1e-3)}});
    out["runs"].push_back(run);
  }
  return out;
}

std::string soilMotionMarkdown(const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& s) {
  std::ostringstream md;
  md << "## Soil motion\n\n"
     << "Region in motion: particles faster than " << s.threshold_m_s * 1e3
     << " mm/s connected to the tool (linked across gaps up to " << mm(s.connect_gap_m) << " mm), its depth below the surface, length and width (Section 3.5); speeds directly in front of the tool (within "
     << mm(s.front_reach_m) << " mm of its front face, across its width, from its tip to the surface); layer mixing = label entropy per "
     << mm(s.mixing_cell_m) << " mm cell over the entropy of all labels (0 untouched, 1 fully mixed).\n\n"
     << (s.rest_run.empty() ? std::string("Velocities as the run has them (no rest run: the bed's own creep counts as motion).\n\n")
                            : "Velocities against the rest run " + s.rest_run.string() +
                                  " (the same bed left alone): the bed's own creep is not counted as motion.\n\n")
     << "| run | displacement (mm) | moving depth (mm) | length (mm) | width (mm) | speed in front (mm/s) | mixing |\n"
        "|---|---|---|---|---|---|---|\n";
  for (const auto& r : runs) {
    md << "| " << r.name << " | before | | | | | " << std::setprecision(3) << r.mixing_before << " |\n";
    for (const auto& in : r.instants)
      md << "| " << r.name << " | " << mm(in.displacement_m) << " | " << mm(in.extent.depth_m) << " | " << mm(in.extent.length_m) << " | "
         << mm(in.extent.width_m) << " | " << mm(in.front.min_m_s) << " - " << mm(in.front.max_m_s) << " (median " << mm(in.front.median_m_s)
         << ", " << in.front.count << " particles) | " << std::setprecision(3) << in.mixing << " |\n";
    md << "| " << r.name << " | after (last frame) | | | | | " << std::setprecision(3) << r.mixing_after << " |\n";
  }
  streamlineTable(md, runs, s);
  md << "\n![vertical sections](plots/velocity-sections.svg)\n\n![horizontal sections](plots/horizontal-sections.svg)\n\n"
        "![layer mixing](plots/mixing.svg)\n";
  return md.str();
}

void writeSoilMotionOutputs(StagedOutput& out, const std::vector<SoilMotionRun>& runs, const SoilMotionSettings& s,
                            const GnuplotRenderer* renderer) {
  out.writeText("soil-motion.json", soilMotionJson(runs, s).dump(2) + "\n");
  out.writeText("soil-motion.md", soilMotionMarkdown(runs, s));
  if (!renderer) return;
  renderSvgAndPng(*renderer, out, sectionsFigure(runs, true), "plots/velocity-sections");
  renderSvgAndPng(*renderer, out, sectionsFigure(runs, false), "plots/horizontal-sections");
  renderSvgAndPng(*renderer, out, mixingFigure(runs), "plots/mixing");
}

}  // namespace demfem::analysis
