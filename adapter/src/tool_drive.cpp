#include "demfem/adapter/tool_drive.hpp"

#include "demfem/study/tool_motion.hpp"

namespace demfem::adapter {

void insertAndStartDrag(CouplingApi& dem, const study::Study& study, const study::Tool& tool) {
  const study::ToolMotionPlan plan = study::planToolMotion(study, tool);
  const double plan_start = dem.time();
  dem.setRigidMotion(tool.name, rigidMotionOf(plan.insertion, plan_start));
  dem.simulate(static_cast<double>(plan.insertion_steps) * plan.dt_s);
  dem.setRigidMotion(tool.name, rigidMotionOf(plan.drag, plan_start));
}

}  // namespace demfem::adapter
