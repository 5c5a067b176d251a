// demfem analysis: the motion a tool causes in the soil (paper Section 3.5, Fig. 16; docs/analysis.md,
// "Soil motion"), computed from the particle files of a run (vtkio: vtk/particles.pvd and the DEM
// tool surfaces vtk/dem-TOOL.pvd). Nothing here knows the simulation: measured particle tracks in the
// same files would be analysed alike.
//
// Contract
// - Units SI, bin frame (docs/architecture.md section 10): x across, y up, z along the bin (travel +z).
// - ParticleFrame: one instant; positions, velocities n x 3, radii, layer labels (0 = top).
// - velocitySection(): the particles whose centre lies within half_thickness of the plane (x = position
//   for Axis::X, the vertical section along the travel; y = position for Axis::Y, a horizontal
//   section) binned into square cells of `cell` from the lowest centre of the frame on each map axis
//   (cell k holds [lowest + k cell, lowest + (k + 1) cell));
//   each cell holds the mean speed |v| of its particles (NaN where a cell has none). Map axes: (z, y)
//   for Axis::X, (z, x) for Axis::Y.
// - flowSection(): on the same plane, thickness and binning as velocitySection(), the cell means of
//   the in-plane velocity components (u along z, v along y for Axis::X, along x for Axis::Y; m/s;
//   NaN where a cell has no particle) and, per cell, the alignment of its moving particles (|v| >
//   threshold): |(1/n) sum v_i/|v_i||, the length of the mean of their 3-D unit velocity vectors
//   (1 all parallel; for n independent random directions its rms is 1/sqrt(n)); NaN below 2 moving
//   particles.
// - alignmentOrder(): the local alignment order of a flow section, the mean of the cells' alignment
//   weighted by their moving particles, over the cells with at least 2; beside it the same weighted
//   mean of 1/sqrt(n), what independent random directions would give. No such cell: cells 0, NaN.
// - traceStreamlines(): the streamline through the centre of every cell in motion (its mean in-plane
//   velocity faster than the threshold). The field at a point is the bilinear interpolation of the
//   cell-centre mean velocities over the surrounding cells in motion (weights renormalised; a
//   linear field is reproduced exactly inside the region). Traced both ways from the seed with the
//   midpoint rule (RK2) at a fixed arc-length step `step_fraction` x cell along the unit direction;
//   a direction ends at the step that would leave the region (its end point in a cell not in
//   motion or off the map), where the interpolated speed is not above the threshold, at a turn of
//   more than `max_step_turn_rad` between consecutive steps (a kink, the flow is not resolved), or
//   when the line's total absolute turning (both directions) would exceed `max_total_turn_rad`
//   (one loop: a closed circle gives its circumference). Points in map coordinates (m).
// - streamlineStatistics(): count, mean and median length (m) of the streamlines, and their mean
//   absolute curvature, total turning over total length (rad/m; 1/r on circles of radius r). No
//   streamline: count 0 and NaN for the rest (no motion is not a length of zero).
// - movingExtent(): the region of the particles faster than `threshold` (|v| > threshold), as the
//   union of their spheres: depth below `surface_y` of its lowest point, its length along z and its
//   width along x. No fast particle: count 0 and zero sizes.
// - connectedMovingExtent(): movingExtent() of the fast particles connected to `seed`: those whose
//   centre lies in the box and every fast particle reached from them through fast particles whose
//   spheres are at most `gap_m` apart (surface to surface). With `seed` the tool's bounds grown by a
//   particle diameter this is the assembly the tool sets in motion, not a lone fast particle
//   elsewhere in the bin (the paper's 83 mm against 55-58 mm is its depth).
// - frontVelocityRange(): speeds of the particles whose centre lies in `box` (in front of the tool:
//   across its width, from its tip to the surface, within reach of its front face). No particle:
//   count 0.
// - layerBoundaries(): heights between vertically adjacent layers of a frame (midway between the
//   lowest centre of the upper layer and the highest centre of the lower one), top layer first.
// - mixingIndex(): H(layer | cell) / H(layer), the Shannon entropy of the layer labels within a cell,
//   weighted by the cell's particles, over the entropy of all labels; cells are columns of `cell` in
//   x and z cut at the given boundary heights. 0 when every cell holds one layer (untouched layers,
//   cut at their boundaries), 1 when every cell holds the labels in the proportions of the whole (a
//   random permutation tends to it). A frame with a single label: 0. mixingSection() maps the same
//   normalised entropy per (z, y) cell (the layer-mixing map).
// - loadRun(): the frames listed by DIR/vtk/particles.pvd and the tool surfaces by DIR/vtk/dem-TOOL.pvd
//   (the only DEM tool collection when `tool` is empty), matched by time (within 1e-9 s);
//   readParticleFrame() one particle file. Both throw InputError naming the file (missing collection,
//   arrays velocity_m_s / radius_m / layer missing or of another size, more than one tool and none
//   chosen, a particle time without a tool file). A run whose DIR/sensors.json exists and says
//   "complete": false (a failed simulation) is refused naming that file; without a sidecar (tracks
//   measured elsewhere) there is nothing to check.
// - toolDisplacement(): the mean z of the tool's nodes at a frame minus at the first frame (the
//   insertion does not move it in z).
// - againstRest(): `frame` with every particle's velocity minus its velocity in `rest`, the same bed
//   left alone (no tool) at the same time: the motion the tool causes, without the bed's own creep
//   (docs/analysis.md, "Soil motion"). The same particles in the same order: InputError naming
//   `rest_file` when the counts or any radius differ.
// - restFrameAt(): the particle file of the rest run `rest_dir` (DIR/vtk/particles.pvd; no tool
//   needed) at time `time_s`, within 1e-6 s; InputError naming the collection when it has none there.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace demfem::analysis {

struct ParticleFrame {
  double time_s = 0;
  std::vector<double> position_m;   // n x 3
  std::vector<double> velocity_m_s; // n x 3
  std::vector<double> radius_m;
  std::vector<int> layer;
  std::size_t size() const { return radius_m.size(); }
  double speed(std::size_t i) const;
};

struct Box {
  std::array<double, 3> lo{0, 0, 0}, hi{0, 0, 0};
  bool contains(const double* p) const;
};

enum class Axis { X, Y };

// A section binned into square cells: mean speed (m/s) of velocitySection(), normalised layer
// entropy of mixingSection().
struct SectionMap {
  Axis axis = Axis::X;
  double position_m = 0, half_thickness_m = 0, cell_m = 0;
  double u0_m = 0, v0_m = 0;      // lower corner of the map (z, then y or x)
  int nu = 0, nv = 0;             // cells along the map's u (z) and v axes
  std::vector<double> values;     // nu x nv, u fastest; NaN = empty cell
  double at(int iu, int iv) const { return values[static_cast<std::size_t>(iv) * nu + iu]; }
};

SectionMap velocitySection(const ParticleFrame& frame, Axis axis, double position_m, double half_thickness_m, double cell_m);

// The in-plane mean velocity and the per-cell alignment of a section (flowSection()).
struct FlowSection {
  SectionMap velocity_u, velocity_v;  // m/s, on the map's u (z) and v axes
  SectionMap alignment;               // |mean unit vector| of the moving particles; NaN below 2
  std::vector<std::size_t> moving;    // moving particles per cell
  double threshold_m_s = 0;
};

FlowSection flowSection(const ParticleFrame& frame, Axis axis, double position_m, double half_thickness_m, double cell_m,
                        double threshold_m_s);

struct AlignmentOrder {
  std::size_t cells = 0, particles = 0;
  double order = 0, random_baseline = 0;  // NaN when cells == 0
};

AlignmentOrder alignmentOrder(const FlowSection& flow);

struct StreamlineRules {
  double step_fraction = 0.25;               // step length / cell
  double max_step_turn_rad = 0.5235987755982988;   // 30 degrees
  double max_total_turn_rad = 6.283185307179586;   // one full turn
};

struct Streamline {
  std::vector<double> u_m, v_m;  // points along the line, map coordinates
  double seed_u_m = 0, seed_v_m = 0;
  double length_m = 0, turning_rad = 0;
};

std::vector<Streamline> traceStreamlines(const FlowSection& flow, const StreamlineRules& rules);

struct StreamlineStatistics {
  std::size_t count = 0;
  double mean_length_m = 0, median_length_m = 0, curvature_rad_per_m = 0;  // NaN when count == 0
};

StreamlineStatistics streamlineStatistics(const std::vector<Streamline>& lines);

struct MovingExtent {
  double threshold_m_s = 0;
  std::size_t count = 0;
  double depth_m = 0, length_m = 0, width_m = 0;
  Box region;                     // the union's bounding box
};

MovingExtent movingExtent(const ParticleFrame& frame, double threshold_m_s, double surface_y_m);
MovingExtent connectedMovingExtent(const ParticleFrame& frame, double threshold_m_s, double surface_y_m, const Box& seed, double gap_m);

struct SpeedRange {
  std::size_t count = 0;
  double min_m_s = 0, median_m_s = 0, max_m_s = 0;
};

SpeedRange frontVelocityRange(const ParticleFrame& frame, const Box& box);

std::vector<double> layerBoundaries(const ParticleFrame& frame);

double mixingIndex(const ParticleFrame& frame, double cell_m, const std::vector<double>& boundaries_y_m);

// The layer mixing along the bin: cells of `cell` in z and y over the whole width, each holding the
// entropy of its particles' labels over the entropy of all labels (0 one layer, 1 fully mixed).
SectionMap mixingSection(const ParticleFrame& frame, double cell_m);

struct ToolFrame {
  double time_s = 0;
  std::vector<double> node_m;  // n x 3, bin frame
  Box bounds() const;
};

// A run's particle files (read one at a time: a frame of the paper's bin is about 1 MB) and its tool.
struct RunFrames {
  std::filesystem::path directory;
  std::string tool;
  std::vector<double> time_s;
  std::vector<std::filesystem::path> particle_files;
  std::vector<ToolFrame> tool_frames;  // one per particle file, at its time
};

RunFrames loadRun(const std::filesystem::path& run_dir, const std::string& tool = "");
ParticleFrame readParticleFrame(const std::filesystem::path& file);

double toolDisplacement(const RunFrames& run, std::size_t frame);

ParticleFrame againstRest(const ParticleFrame& frame, const ParticleFrame& rest, const std::filesystem::path& rest_file);
std::filesystem::path restFrameAt(const std::filesystem::path& rest_dir, double time_s);

}  // namespace demfem::analysis
