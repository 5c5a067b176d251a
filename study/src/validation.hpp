// Private to the study library: the cross-field rules of a study (layers tile the soil, the
// interaction table covers every pair, tools fit their constraints and the bin, sizes the programs
// are built for), run after its keys were read (load.cpp). docs/study-file.md states the rules.
#pragma once

#include "demfem/study/study.hpp"

#include "json_reader.hpp"

#include <string>
#include <vector>

namespace demfem::study::detail {

// What reading found: the problems it reported (a rule whose inputs were reported is not judged
// again) and, per tool, whether the file gave motion.center_x_mm (else the bin centre line).
struct ReadFacts {
  const std::vector<Issue>& reading;
  const std::vector<bool>& center_x_given;
  // True if reading reported a problem at `path` or at an object or array containing it.
  bool bad(const std::string& path) const;
};

void checkStudy(const Study& study, const ReadFacts& facts, IssueList& issues);

// Letters, digits, '_', '-' and '.' only (names of output files and backends).
bool isPlainName(const std::string& name);

}  // namespace demfem::study::detail
