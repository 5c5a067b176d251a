#include "demfem/study/study.hpp"

#include "enum_names.hpp"

#include <sstream>

namespace demfem::study {

namespace {
std::string formatIssues(const std::string& file, const std::vector<Issue>& issues) {
  std::ostringstream out;
  for (std::size_t i = 0; i < issues.size(); ++i) {
    if (i) out << '\n';
    out << file << ": ";
    if (!issues[i].path.empty()) out << issues[i].path << ": ";
    out << issues[i].message;
  }
  return out.str();
}
}  // namespace

namespace {
// File names and messages may quote bytes of a broken file: keep them printable and JSON-safe.
std::vector<Issue> printable(std::vector<Issue> issues) {  // by value: sanitises a copy
  for (Issue& issue : issues) {
    issue.path = validUtf8(issue.path);
    issue.message = validUtf8(issue.message);
  }
  return issues;
}
}  // namespace

StudyError::StudyError(std::string file, std::vector<Issue> issues)
    : std::runtime_error(formatIssues(validUtf8(file), printable(issues))),
      file_(validUtf8(file)),
      issues_(printable(std::move(issues))) {}

const DemMaterial& Study::material(const std::string& name) const {
  for (const DemMaterial& m : soil.materials)
    if (m.name == name) return m;
  throw std::out_of_range("study " + this->name + ": no material \"" + name + "\" in /soil/materials");
}

const Interaction& Study::interaction(const std::string& a, const std::string& b) const {
  for (const Interaction& i : soil.interactions)
    if ((i.a == a && i.b == b) || (i.a == b && i.b == a)) return i;
  throw std::out_of_range("study " + name + ": no interaction for (\"" + a + "\", \"" + b +
                          "\") in /soil/interactions");
}

}  // namespace demfem::study
