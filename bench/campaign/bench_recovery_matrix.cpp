// Recovery-matrix benchmark (docs/diagnosis.md, "Recovery matrix"): --draws hidden effects of master
// seed --seed (tests/campaign/hidden_effects.hpp: single catalogue effects, pairs, effects outside
// the catalogue and null cases in weight drops of the narrow PMMA tool, from an independent
// CalculiX model), each diagnosed by the `demfem diagnose` executable as a child process (with the
// generator's measured --model-form-percent, recovery_matrix.hpp), --jobs at a time (one thread
// each). Prints the matrix per catalogue entry, the acceptance targets with their
// one-sided 95 % Clopper-Pearson bounds, and every draw; --json writes the same.
//
// Resumable: every finished draw is appended to --log (JSON lines: seed, index, verdict, causes,
// wall time); a run with the same log and seed skips the draws already there (the draws are
// deterministic, so the log's answers are scored again against the same hidden effects).
#include "bench_timing.hpp"
#include "demfem/cli/cli_support.hpp"
#include "recovery_matrix.hpp"

#include <cstdio>
#include <fstream>
#include <map>

namespace {

using namespace demfem;
using namespace demfem::campaign::test;

struct Options {
  int draws = 200, jobs = 2, diagnosis_jobs = 1;
  std::uint64_t seed = 1;
  std::string log = "recovery-matrix-draws.jsonl", work = "recovery-matrix-work";
  std::string demfem = std::string(DEMFEM_BINARY_DIR) + "/apps/demfem";
  std::string study = std::string(DEMFEM_SOURCE_DIR) + "/tests/campaign/data/narrow_weight_drop.json";
};

// The answers of the log's lines of `seed`, by draw index.
std::map<int, Answer> readLog(const std::string& file, std::uint64_t seed) {
  std::map<int, Answer> done;
  std::ifstream in(file);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty()) continue;
    const auto j = nlohmann::json::parse(line);
    if (j.at("seed").get<std::uint64_t>() != seed) continue;
    Answer a;
    a.verdict = j.at("verdict").get<std::string>();
    a.causes = j.at("causes").get<std::vector<std::string>>();
    a.wall_s = j.at("wall_s").get<double>();
    done[j.at("index").get<int>()] = a;
  }
  return done;
}

nlohmann::json run(const Options& o, std::FILE* table) {
  const std::map<int, Answer> logged = readLog(o.log, o.seed);
  RunSettings settings;
  settings.demfem = o.demfem;
  settings.study = o.study;
  settings.diagnosis_jobs = o.diagnosis_jobs;
  std::ofstream log(o.log, std::ios::app);
  int finished = 0;
  const auto start = bench::Clock::now();
  auto scored = runDraws(
      o.seed, 0, o.draws, o.jobs, o.work, settings, [&](int i) { return logged.count(i) > 0; },
      [&](const Scored& s) {
        nlohmann::json line = drawJson(s);
        line["seed"] = o.seed;
        log << line.dump() << std::endl;
        std::fprintf(stderr, "draw %d (%d new, %.0f s): %s -> %s\n", s.draw.index, ++finished, bench::secondsSince(start), s.draw.describe().c_str(),
                     s.answer.verdict.c_str());
      });
  const double wall_s = bench::secondsSince(start);
  for (const auto& [index, answer] : logged)
    if (index < o.draws) scored.push_back(score(drawCase(o.seed, index), answer));
  std::sort(scored.begin(), scored.end(), [](const Scored& a, const Scored& b) { return a.draw.index < b.draw.index; });
  std::filesystem::remove_all(o.work);

  std::fprintf(table, "%s", matrixMarkdown(scored).c_str());
  double diagnosis_s = 0;
  for (const Scored& s : scored) diagnosis_s += s.answer.wall_s;
  std::fprintf(table, "\n%zu draws (%zu from the log), seed %llu; this run %.0f s wall; mean diagnosis %.1f s wall\n", scored.size(), logged.size(),
               static_cast<unsigned long long>(o.seed), wall_s, scored.empty() ? 0.0 : diagnosis_s / static_cast<double>(scored.size()));

  nlohmann::json draws = nlohmann::json::array(), target_json = nlohmann::json::array();
  for (const Scored& s : scored) draws.push_back(drawJson(s));
  for (const Target& t : targets(scored))
    target_json.push_back({{"name", t.name}, {"successes", t.k}, {"draws", t.n}, {"rate", t.rate()}, {"target", t.target}, {"at_least", t.at_least},
                           {"clopper_pearson_95_bound", t.bound()}, {"rejected", t.rejected()}});
  return {{"seed", o.seed}, {"draws", draws}, {"targets", target_json}, {"matrix_csv", matrixCsv(scored)}, {"run_wall_s", wall_s}};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-recovery-matrix: the recovery matrix of demfem diagnose on drawn hidden effects in weight drops"};
  app.name("demfem-bench-recovery-matrix");
  Options o;
  app.add_option("--draws", o.draws, "Draws (indices 0 .. N-1 of the seed's sequence)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--seed", o.seed, "Master seed of the draws")->capture_default_str();
  app.add_option("--jobs", o.jobs, "Diagnoses run at once")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--diagnosis-jobs", o.diagnosis_jobs, "--jobs of each diagnosis")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--log", o.log, "Draws done so far, appended as they finish (JSON lines; resumed from)")->capture_default_str();
  app.add_option("--work", o.work, "Working directory of the recordings and diagnoses (removed at the end)")->capture_default_str();
  app.add_option("--demfem", o.demfem, "The demfem executable")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--study", o.study, "Weight-drop study of the narrow tool")->check(CLI::ExistingFile)->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] { cli::writeJson(json_target, run(o, cli::textStream(json_target))); });
  return cli::runApp(app, argc, argv);
}
