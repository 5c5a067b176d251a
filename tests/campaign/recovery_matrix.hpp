// Test fixture: the recovery matrix (docs/diagnosis.md, "Recovery matrix"). Runs the `demfem diagnose`
// executable as a child process on the recordings of drawn hidden effects (hidden_effects.hpp),
// reads its JSON (only `verdict` and `causes`, or `cause` where `causes` is absent), scores each
// answer against what was hidden, and tabulates the scores per catalogue entry with the targets of
// the acceptance test and their exact binomial (Clopper-Pearson) bounds. Shares no code with the
// diagnosis.
#pragma once

#include "hidden_effects.hpp"
#include "support/spawn.hpp"

#include <nlohmann/json.hpp>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <mutex>
#include <sstream>
#include <string>
#include <thread>
#include <vector>


namespace demfem::campaign::test {

namespace fs = std::filesystem;

inline const char* kNoDiscrepancy = "no significant discrepancy";
inline const char* kCause = "cause";
inline const char* kUnexplained = "unexplained discrepancy";

struct Answer {
  std::string verdict;              // one of the three, or "error: ..." when the run failed
  std::vector<std::string> causes;  // named cause ids
  double wall_s = 0;
};

// Reads the diagnosis' JSON: `verdict`, and `causes` (array) or else `cause` (id or null).
inline Answer answerFromJson(const nlohmann::json& j) {
  Answer a;
  a.verdict = j.at("verdict").get<std::string>();
  if (j.contains("causes")) {
    for (const auto& c : j.at("causes")) a.causes.push_back(c.get<std::string>());
  } else if (j.contains("cause") && !j.at("cause").is_null()) {
    a.causes.push_back(j.at("cause").get<std::string>());
  }
  return a;
}

// Runs `args` with stdout and stderr to `log_stem`.out/.err; returns the wait status (-1: killed at
// `limit`).
inline int runProcess(std::vector<std::string> args, const fs::path& log_stem, std::chrono::seconds limit) {
  const pid_t pid = support::spawnLogged(std::move(args), log_stem.string() + ".out", log_stem.string() + ".err");
  const auto deadline = std::chrono::steady_clock::now() + limit;
  int status = 0;
  while (waitpid(pid, &status, WNOHANG) != pid) {
    if (std::chrono::steady_clock::now() > deadline) {
      kill(pid, SIGKILL);
      waitpid(pid, nullptr, 0);
      return -1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return status;
}

struct RunSettings {
  std::string demfem;      // the executable
  fs::path study;          // narrow_weight_drop.json
  int diagnosis_jobs = 1;  // --jobs of each diagnosis
  // --model-form-percent: what the generator's null differs from the project's plate model by, the
  // largest residual of the calibrated baseline on a noiseless null (0.025 %, the light weight's
  // frequency; docs/diagnosis.md, "Recovery matrix"), rounded up.
  std::string model_form_percent = "0.03";
  std::chrono::seconds limit{900};
};

// Writes the draw's recordings under `work`, diagnoses them and reads the answer; a failed run is
// an answer "error: ..." (scored as a wrong answer).
inline Answer diagnoseDraw(const Draw& d, const fs::path& work, const RunSettings& s) {
  fs::remove_all(work);
  writeDrawRecordings(d, work / "recordings");
  const auto start = std::chrono::steady_clock::now();
  const int status = runProcess({s.demfem, "diagnose", s.study.string(), (work / "recordings").string(), "--json", (work / "diagnosis.json").string(),
                                 "--out", (work / "out").string(), "--no-plots", "--quiet", "--jobs", std::to_string(s.diagnosis_jobs), "--model-form-percent", s.model_form_percent},
                                work / "diagnose", s.limit);
  const double wall = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  Answer a;
  if (status == -1) {
    a.verdict = "error: no answer within " + std::to_string(s.limit.count()) + " s";
  } else if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream err(work / "diagnose.err");
    std::stringstream text;
    text << err.rdbuf();
    a.verdict = "error: exit status " + std::to_string(WIFEXITED(status) ? WEXITSTATUS(status) : -1) + ": " + text.str().substr(0, 300);
  } else {
    std::ifstream in(work / "diagnosis.json");
    a = answerFromJson(nlohmann::json::parse(in));
  }
  a.wall_s = wall;
  return a;
}

// Today's main names one cause `sensor_gain` for both channels' gains: it counts as naming either.
inline bool names(const Answer& a, const std::string& hidden) {
  for (const auto& c : a.causes)
    if (c == hidden || (c == "sensor_gain" && (hidden == "force_sensor_gain" || hidden == "deformation_sensor_gain"))) return true;
  return false;
}

struct Scored {
  Draw draw;
  Answer answer;
  bool all_named = false;     // every hidden catalogue effect named (singles and pairs)
  bool wrong_named = false;   // a cause named that was not hidden
  bool at_twice = false;      // every hidden effect at >= 2x its detectable size
  std::vector<std::string> wrong;
};

inline Scored score(const Draw& d, const Answer& a) {
  Scored s;
  s.draw = d, s.answer = a;
  s.all_named = d.cls == DrawClass::Single || d.cls == DrawClass::Pair;
  s.at_twice = !d.effects.empty();
  for (const Effect& e : d.effects) {
    if (e.info().in_catalogue && !names(a, e.info().id)) s.all_named = false;
    if (e.multiple() < 2) s.at_twice = false;
  }
  for (const auto& c : a.causes) {
    const bool hidden = std::any_of(d.effects.begin(), d.effects.end(), [&](const Effect& e) {
      return e.info().in_catalogue && names(Answer{"", {c}}, e.info().id);
    });
    if (!hidden) s.wrong_named = true, s.wrong.push_back(c);
  }
  return s;
}

// Exact binomial tail P(X <= k) for X ~ B(n, p).
inline double binomialCdf(int k, int n, double p) {
  if (k < 0) return 0;
  if (k >= n) return 1;
  double sum = 0;
  for (int i = 0; i <= k; ++i) sum += std::exp(std::lgamma(n + 1.0) - std::lgamma(i + 1.0) - std::lgamma(n - i + 1.0) + i * std::log(p) + (n - i) * std::log1p(-p));
  return std::min(1.0, sum);
}

// One-sided Clopper-Pearson bounds at confidence 1 - alpha for k successes in n: the upper bound
// is the p with P(X <= k | p) = alpha, the lower one the p with P(X >= k | p) = alpha.
inline double clopperPearsonUpper(int k, int n, double alpha) {
  if (k >= n) return 1;
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) ((binomialCdf(k, n, 0.5 * (lo + hi)) > alpha) ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}
inline double clopperPearsonLower(int k, int n, double alpha) {
  if (k <= 0) return 0;
  double lo = 0, hi = 1;
  for (int i = 0; i < 60; ++i) ((1 - binomialCdf(k - 1, n, 0.5 * (lo + hi)) < alpha) ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

// A target of the acceptance test: a rate of at least (or at most) `target` over `n` draws. It is
// rejected when the one-sided 95 % Clopper-Pearson bound lies on the wrong side of it (the upper
// bound of a success rate below the target, the lower bound of an error rate above it), i.e. when
// the draws show at 95 % confidence that the method misses the target. Passing does not show the
// target is met: with 30 draws only a gross miss is detected (docs/diagnosis.md).
struct Target {
  std::string name;
  int k = 0, n = 0;
  double target = 0;
  bool at_least = true;
  double rate() const { return n ? static_cast<double>(k) / n : 0.0; }
  double bound() const { return at_least ? clopperPearsonUpper(k, n, 0.05) : clopperPearsonLower(k, n, 0.05); }
  bool rejected() const { return n > 0 && (at_least ? bound() < target : bound() > target); }
};

inline std::vector<Target> targets(const std::vector<Scored>& scored) {
  Target power{"power: single catalogue effects at >= 2x named", 0, 0, 0.95, true};
  Target false_discoveries{"false discoveries: catalogue draws naming a cause not hidden", 0, 0, 0.05, false};
  Target false_alarms{"null false alarms: null draws not answered 'no significant discrepancy'", 0, 0, 0.05, false};
  Target outside{"outside the catalogue: answered 'unexplained discrepancy', no cause named", 0, 0, 0.90, true};
  Target pairs{"pairs at >= 2x: both members named", 0, 0, 0.80, true};
  for (const Scored& s : scored) {
    switch (s.draw.cls) {
      case DrawClass::Single:
        if (s.at_twice) ++power.n, power.k += s.all_named;
        ++false_discoveries.n, false_discoveries.k += s.wrong_named;
        break;
      case DrawClass::Pair:
        if (s.at_twice) ++pairs.n, pairs.k += s.all_named;
        ++false_discoveries.n, false_discoveries.k += s.wrong_named;
        break;
      case DrawClass::OutsideCatalogue:
        ++outside.n, outside.k += s.answer.verdict == kUnexplained && s.answer.causes.empty();
        break;
      case DrawClass::Null:
        ++false_alarms.n, false_alarms.k += s.answer.verdict != kNoDiscrepancy;
        break;
    }
  }
  return {power, false_discoveries, false_alarms, outside, pairs};
}

// One row per hidden effect kind (pairs counted under both members), then pairs, nulls: draws,
// those at >= 2x, named (all sizes, >= 2x), a wrong cause named, and the verdicts.
struct MatrixRow {
  std::string hidden;
  int draws = 0, at_twice = 0, named = 0, named_at_twice = 0, wrong = 0, no_discrepancy = 0, cause = 0, unexplained = 0, errors = 0;
  std::map<std::string, int> wrong_ids;
};

inline std::vector<MatrixRow> matrixRows(const std::vector<Scored>& scored) {
  std::vector<MatrixRow> rows;
  const auto row = [](const std::string& hidden) {
    MatrixRow r;
    r.hidden = hidden;
    return r;
  };
  for (const auto& k : effectKinds()) rows.push_back(row(k.id));
  rows.push_back(row("pair (both named)"));
  rows.push_back(row("null"));
  const auto add = [](MatrixRow& r, const Scored& s, bool named, bool at_twice) {
    ++r.draws, r.at_twice += at_twice, r.named += named, r.named_at_twice += named && at_twice, r.wrong += s.wrong_named;
    const std::string& v = s.answer.verdict;
    r.no_discrepancy += v == kNoDiscrepancy, r.cause += v == kCause, r.unexplained += v == kUnexplained;
    r.errors += v != kNoDiscrepancy && v != kCause && v != kUnexplained;
    for (const auto& w : s.wrong) ++r.wrong_ids[w];
  };
  for (const Scored& s : scored) {
    for (const Effect& e : s.draw.effects)
      add(rows[static_cast<std::size_t>(e.kind)], s, e.info().in_catalogue ? names(s.answer, e.info().id) : s.answer.verdict == kUnexplained && s.answer.causes.empty(),
          e.multiple() >= 2);
    if (s.draw.cls == DrawClass::Pair) add(rows[effectKinds().size()], s, s.all_named, s.at_twice);
    if (s.draw.cls == DrawClass::Null) add(rows.back(), s, s.answer.verdict == kNoDiscrepancy, false);
  }
  return rows;
}

inline std::string wrongIds(const MatrixRow& r) {
  std::string s;
  for (const auto& [id, n] : r.wrong_ids) s += (s.empty() ? "" : " ") + id + "x" + std::to_string(n);
  return s;
}

// The matrix as CSV (one line per row, `named` meaning: catalogue rows the effect named, outside
// rows 'unexplained' with no cause, the null row 'no significant discrepancy').
inline std::string matrixCsv(const std::vector<Scored>& scored) {
  std::ostringstream o;
  o << "hidden,draws,draws_at_2x,named,named_at_2x,wrong_cause_named,no_significant_discrepancy,cause,unexplained_discrepancy,errors,wrong_causes\n";
  for (const auto& r : matrixRows(scored))
    o << r.hidden << ',' << r.draws << ',' << r.at_twice << ',' << r.named << ',' << r.named_at_twice << ',' << r.wrong << ',' << r.no_discrepancy << ','
      << r.cause << ',' << r.unexplained << ',' << r.errors << ',' << wrongIds(r) << '\n';
  return o.str();
}

inline std::string percent(int k, int n) {
  if (n == 0) return "-";
  char buf[40];
  std::snprintf(buf, sizeof buf, "%d/%d (%.0f %%)", k, n, 100.0 * k / n);
  return buf;
}

// The matrix, the targets and every draw as Markdown.
inline std::string matrixMarkdown(const std::vector<Scored>& scored) {
  std::ostringstream o;
  o << "| hidden | draws | named (all sizes) | named at >= 2x | wrong cause named | no discrepancy / cause / unexplained / error | wrong causes |\n"
    << "| --- | --- | --- | --- | --- | --- | --- |\n";
  for (const auto& r : matrixRows(scored))
    o << "| " << r.hidden << " | " << r.draws << " | " << percent(r.named, r.draws) << " | " << percent(r.named_at_twice, r.at_twice) << " | "
      << percent(r.wrong, r.draws) << " | " << r.no_discrepancy << " / " << r.cause << " / " << r.unexplained << " / " << r.errors << " | " << wrongIds(r) << " |\n";
  o << "\n| target | draws | rate | one-sided 95 % Clopper-Pearson bound | target | verdict |\n| --- | --- | --- | --- | --- | --- |\n";
  for (const Target& t : targets(scored)) {
    char buf[300];
    std::snprintf(buf, sizeof buf, "| %s | %d | %s | %s %.3f | %s %.2f | %s |\n", t.name.c_str(), t.n, percent(t.k, t.n).c_str(), t.at_least ? "upper" : "lower",
                  t.bound(), t.at_least ? ">=" : "<=", t.target, t.n == 0 ? "no draws" : t.rejected() ? "missed" : "not rejected");
    o << buf;
  }
  o << "\n| draw | class | hidden | verdict | named | wall (s) |\n| --- | --- | --- | --- | --- | --- |\n";
  for (const Scored& s : scored) {
    std::string named;
    for (const auto& c : s.answer.causes) named += (named.empty() ? "" : ", ") + c;
    char wall[20];
    std::snprintf(wall, sizeof wall, "%.1f", s.answer.wall_s);
    o << "| " << s.draw.index << " | " << className(s.draw.cls) << " | " << s.draw.describe() << " | " << s.answer.verdict << " | " << named << " | " << wall << " |\n";
  }
  return o.str();
}

// One draw's record (the benchmark's log line; also its JSON).
inline nlohmann::json drawJson(const Scored& s) {
  nlohmann::json effects = nlohmann::json::array();
  for (const Effect& e : s.draw.effects)
    effects.push_back({{"id", e.info().id}, {"variant", e.variant}, {"amount", e.amount}, {"amount_unit", e.info().amount_unit},
                       {"detectable_amount", e.detectable}, {"size_in_detectable", e.multiple()}});
  return {{"index", s.draw.index},         {"class", className(s.draw.cls)}, {"effects", effects},          {"verdict", s.answer.verdict},
          {"causes", s.answer.causes},     {"wall_s", s.answer.wall_s},       {"all_named", s.all_named},     {"wrong_cause_named", s.wrong_named}};
}

// Runs draws [first, first + count) of `master_seed` with `jobs` diagnoses at once (each its own
// work directory under `work`); `skip(index)` leaves out draws already done, `done(scored)` is
// called (serialised) as each finishes. Returns the scored draws in index order.
inline std::vector<Scored> runDraws(std::uint64_t master_seed, int first, int count, int jobs, const fs::path& work, const RunSettings& s,
                                    const std::function<bool(int)>& skip, const std::function<void(const Scored&)>& done) {
  std::vector<int> todo;
  for (int i = first; i < first + count; ++i)
    if (!skip(i)) todo.push_back(i);
  std::vector<Scored> out;
  std::mutex mutex;
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> threads;
  for (int j = 0; j < std::max(1, jobs); ++j)
    threads.emplace_back([&, j] {
      for (std::size_t t = next++; t < todo.size(); t = next++) {
        const Draw d = drawCase(master_seed, todo[t]);
        Answer a;
        try {
          a = diagnoseDraw(d, work / ("job" + std::to_string(j)), s);
        } catch (const std::exception& e) {
          a.verdict = std::string("error: ") + e.what();
        }
        const Scored sc = score(d, a);
        const std::lock_guard lock(mutex);
        out.push_back(sc);
        done(sc);
      }
    });
  for (auto& t : threads) t.join();
  std::sort(out.begin(), out.end(), [](const Scored& a, const Scored& b) { return a.draw.index < b.draw.index; });
  return out;
}

}  // namespace demfem::campaign::test
