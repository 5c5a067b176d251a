#include "demfem/fem/tool_model.hpp"
