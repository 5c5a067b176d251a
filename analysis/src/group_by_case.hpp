// Internal: items (runs) grouped by their case key, in key order, preserving input order within a case.
#pragma once

#include "demfem/analysis/recording.hpp"

#include <map>
#include <vector>

namespace demfem::analysis::detail {

template <class Item>
std::map<CaseKey, std::vector<const Item*>> groupByCase(const std::vector<Item>& items) {
  std::map<CaseKey, std::vector<const Item*>> groups;
  for (const auto& item : items) groups[item.key].push_back(&item);
  return groups;
}

}  // namespace demfem::analysis::detail
