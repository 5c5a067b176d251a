// Translation of a demfem study into LIGGGHTS-PUBLIC 3.8 input commands (docs/architecture.md sections 6 and 11;
// docs/liggghts-backend.md maps every study input onto the LIGGGHTS one and says where they differ).
// Pure text: no LIGGGHTS or MPI header is needed here, so the translation is testable on its own.
//
// Contract
// - Units: the deck uses LIGGGHTS `units si` (m, kg, s, N), like the Study.
// - Bin frame (docs/architecture.md section 10): x across the bin, x in [0, W]; y up, floor at y = 0; z along the
//   bin, z in [0, bin length] (the frame of the built-in backend and the FEM client). The bin walls are primitive planes; the box is
//   larger than the bin so that the tools stay inside it over their whole stroke.
// - Atom types: 1..P the particle materials in the order they first appear in soil.layers, then the
//   bin-wall material, then each tool's material (types are per material, so two tools of one
//   material share a type). Per-type-pair tables come from soil.interactions (Table 2/4); pairs that
//   can never touch (wall-wall, wall-tool, tool-tool) get the neutral values of kNeverTouching.
// - Tools: tool i is the mesh/surface/stress fix `tool<i>`, read from `<stl_dir>/tool<i>.stl` (written
//   by writeToolStl), translated to its start position (toolStartOrigin) and moved by
//   `move/mesh ... linear/variable` with the equal-style variables `tool<i>_vx/_vy/_vz` (m/s).
// - Deposition: each layer is inserted once by insert/pack into its own slab of a stretched stack
//   (bottom layer lowest), so that after settling under gravity the layers lie in study order;
//   particles whose centre ends above soil.fill_height_m are then removed (as the built-in backend
//   does; the stack is sized to overfill slightly). The
//   tools come after it: particles closer than r_max to a tool's start position are deleted, then the
//   tool meshes are created (a tool present during deposition keeps particles from settling).
// - Errors: translateStudy() throws adapter::CouplingError(Unsupported) naming the study field when
//   the study uses a model LIGGGHTS-PUBLIC does not have (the EDEM-style laws), or BadRequest when a
//   value would make LIGGGHTS stop the process (LIGGGHTS input errors call exit()).
#pragma once

#include "demfem/adapter/tool_surface.hpp"
#include "demfem/study/study.hpp"

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace demfem::liggghts {

// Commands split in the phases the backend runs them in.
struct InputDeck {
  std::vector<std::string> setup;           // box, materials, contact model, bin walls, gravity, output
  std::vector<std::string> deposition;      // particle templates and insertion (run before settling)
  std::vector<std::string> trim;            // after settling: remove particles centred above the fill
  std::vector<std::string> tool_clearance;  // after settling: remove particles in the tools' way
  std::vector<std::string> tools;           // tool meshes, their wall and movers
  int atom_type_count = 0;
  double time_step_s = 0;               // physics::demTimeStep (backends/physics/time_step.hpp) shortened to divide fem.dt_s
  double fall_time_s = 0;               // free fall from the top of the insertion stack to the floor
};

// The LIGGGHTS atom type (1-based) of a material under the ordering above; throws BadRequest for a
// material that is not used by the study's layers, bin or tools.
int atomType(const study::Study& study, const std::string& material);

// Bin position of tool i's local origin at the start (after deposition): the start pose of its motion
// plan (study/tool_motion.hpp: x = motion.center_x_m, tip one largest particle diameter above the
// settled surface, front face at motion.start_z_m). Only the client moves it (setRigidMotion).
std::array<double, 3> toolStartOrigin(const study::Study& study, std::size_t tool_index);

// The keypoint surface of tool i (plate tools only; other geometry kinds throw Unsupported).
adapter::ToolSurface toolSurface(const study::Study& study, std::size_t tool_index);

// Writes `surface` as an ASCII STL, every node translated by `origin` (bin frame, metres).
void writeToolStl(const adapter::ToolSurface& surface, const std::array<double, 3>& origin,
                  const std::filesystem::path& file);

// Translates `study` (validated by study::loadStudy) into LIGGGHTS commands; tool STL files are
// expected in `stl_dir` under the names given above.
InputDeck translateStudy(const study::Study& study, const std::filesystem::path& stl_dir);

}  // namespace demfem::liggghts
