#include "demfem/study/study.hpp"

#include <sstream>

namespace demfem::study {

namespace {
std::string formatIssues(const std::string& file, const std::vector<Issue>& issues) {
  std::ostringstream out;
  for (std::size_t i = 0; i < issues.size(); ++i) {
    if (i) out << '\n';
    out << file << ": " << issues[i].path << ": " << issues[i].message;
  }
  return out.str();
}
}  // namespace

StudyError::StudyError(std::string file, std::vector<Issue> issues)
    : std::runtime_error(formatIssues(file, issues)), file_(std::move(file)), issues_(std::move(issues)) {}

}  // namespace demfem::study
