#include "demfem/cli/cli_support.hpp"

#include "demfem/adapter/output_files.hpp"
#include "demfem/study/study.hpp"

#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>

namespace demfem::cli {

int runApp(CLI::App& app, int argc, char** argv) {
  const std::string prog = app.get_name();
  try {
    app.parse(argc, argv);
    return kOk;
  } catch (const CLI::ParseError& e) {
    return app.exit(e) == 0 ? kOk : kBadInput;
  } catch (const study::StudyError& e) {
    std::cerr << e.what() << '\n';
    return kBadInput;
  } catch (const InputError& e) {
    std::cerr << prog << ": " << e.what() << '\n';
    return kBadInput;
  } catch (const Interrupted& e) {
    std::cerr << prog << ": " << e.what() << '\n';
    return kInterrupted;
  } catch (const std::exception& e) {
    std::cerr << prog << ": error: " << e.what() << '\n';
    return kFailure;
  }
}

std::string& addJsonOption(CLI::App& cmd) {
  auto target = std::make_shared<std::string>();
  // CLI11 binds by reference; keep the string alive as long as the App by storing it in a static
  // registry owned by this translation unit.
  static std::vector<std::shared_ptr<std::string>> keep;
  keep.push_back(target);
  cmd.add_option("--json", *target,
                 "Also write the reported numbers as JSON to FILE ('-' = standard output); "
                 "units are in the key names");
  return *target;
}

void addPlotOptions(CLI::App& cmd, bool& no_plots, std::string& gnuplot, const std::string& plots) {
  cmd.add_flag("--no-plots", no_plots, "Do not draw the " + plots);
  cmd.add_option("--gnuplot", gnuplot, "gnuplot executable of the " + plots)->capture_default_str();
}

void addAllowUnsettledSoilFlag(CLI::App& cmd, bool& allow) {
  cmd.add_flag("--allow-unsettled-soil", allow,
               "Run even if the settled soil is not settled (a settling stage hit its time cap or the kinetic energy is "
               "above the study's threshold); refused by default, the soil's figures are recorded with the run");
}

void writeJson(const std::string& target, const nlohmann::json& doc) {
  if (target.empty()) return;
  if (target == "-") {
    std::cout << doc.dump(2) << '\n';
    return;
  }
  adapter::writeFileAtomically(target, doc.dump(2) + "\n");
}

nlohmann::ordered_json readJsonFile(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError("cannot read " + file.string());
  try {
    return nlohmann::ordered_json::parse(in);
  } catch (const nlohmann::json::parse_error& e) {
    throw InputError(file.string() + ": not JSON: " + e.what());
  }
}

}  // namespace demfem::cli
