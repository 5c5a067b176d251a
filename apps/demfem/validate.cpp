// `demfem validate STUDY...`: checks study files and prints their effective values with units.
#include "commands.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <iostream>
#include <memory>
#include <string>
#include <vector>

namespace demfem::cli {

void addValidateCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand(
      "validate",
      "Check study files (type, unit, range and cross-field rules of every key; docs/study-file.md) and print "
      "every effective value with its unit, defaults included. Every problem is reported as "
      "'FILE: JSON-PATH: MESSAGE'; exit code 2 if any file is invalid.");
  auto files = std::make_shared<std::vector<std::string>>();
  cmd->add_option("STUDY", *files, "Study files (JSON)")->required()->check(CLI::ExistingFile);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([files, &json_target] {
    nlohmann::json report{{"studies", nlohmann::json::array()}};
    std::size_t invalid = 0;
    const bool text = json_target != "-";  // stdout carries the JSON document instead
    for (const std::string& file : *files) {
      try {
        const study::Study s = study::loadStudy(file);
        const std::string hash = study::hasSoil(s.kind) ? study::soilHash(s) : std::string();
        if (text) {
          std::cout << "# " << file << ": valid\n" << study::describe(s);
          if (!hash.empty()) std::cout << "soil_hash = " << hash << '\n';
          std::cout << '\n';
        }
        nlohmann::json entry{{"file", study::validUtf8(file)}, {"valid", true}, {"effective", study::toJson(s)}};
        if (!hash.empty()) entry["soil_hash"] = hash;
        report["studies"].push_back(entry);
      } catch (const study::StudyError& e) {
        ++invalid;
        std::cerr << e.what() << '\n';
        nlohmann::json problems = nlohmann::json::array();
        for (const study::Issue& issue : e.issues()) problems.push_back({{"path", issue.path}, {"message", issue.message}});
        report["studies"].push_back({{"file", e.file()}, {"valid", false}, {"issues", problems}});
      }
    }
    writeJson(json_target, report);
    if (invalid > 0)
      throw InputError(std::to_string(invalid) + " of " + std::to_string(files->size()) + " study file(s) invalid");
  });
}

}  // namespace demfem::cli
