// `demfem run STUDY`: a local coupled run as two processes, demfem-dem (the study's DEM backend) and
// demfem-fem (the FEM client), connected over ipc://. Both executables are found next to this one.
// Ctrl-C / SIGTERM are forwarded to both; if either fails, the other is stopped. The FEM client
// leaves its outputs complete or marked incomplete (fem/coupled_driver.hpp).
// The ipc socket lives in a private run directory (mkdtemp: mode 0700, unpredictable name, never an
// existing directory). The children die with this process (PR_SET_PDEATHSIG), also when it is
// killed by SIGKILL; its run directory is then removed by the next `demfem run` of the same user.
#include "commands.hpp"

#include "demfem/adapter/settled_soil.hpp"
#include "demfem/cli/backend_registry.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/soil_supply.hpp"
#include "demfem/study/study.hpp"

#include <signal.h>
#include <sys/prctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstring>
#include <fstream>
#include <chrono>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <thread>

extern char** environ;

namespace demfem::cli {

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

std::atomic<int> g_forward_signal{0};
extern "C" void onForwardedSignal(int signal) { g_forward_signal = signal; }

struct RunOptions {
  std::string study_file;
  std::string output_dir;
  std::string backend;
  std::int64_t steps = 0;
  std::int64_t checkpoint_every = 0;
  int threads = 0;
  bool resume = false;
  bool quiet = false;
  bool allow_unsettled_soil = false;
};

// A child process (fork + exec); waited for at most once. It gets SIGTERM when this process dies,
// however it dies (the FEM client then marks its outputs incomplete).
class Child {
 public:
  Child(std::string name, const std::vector<std::string>& args) : name_(std::move(name)) {
    std::vector<char*> argv;
    for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    const pid_t parent = getpid();
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("cannot start " + args[0] + ": " + std::strerror(errno));
    if (pid_ == 0) {
      // Only async-signal-safe calls here. If the parent died before prctl, getppid() tells.
      if (prctl(PR_SET_PDEATHSIG, SIGTERM) != 0 || getppid() != parent) _exit(127);
      execve(argv[0], argv.data(), environ);
      _exit(127);
    }
  }
  ~Child() {
    if (running()) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  const std::string& name() const { return name_; }
  bool running() const { return !status_; }
  // Non-blocking: true once the child has exited.
  bool poll() {
    if (status_) return true;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) status_ = status;
    return status_.has_value();
  }
  void signal(int sig) const {
    if (!status_) kill(pid_, sig);
  }
  // SIGTERM, then SIGKILL if it has not exited after `grace`.
  void stop(std::chrono::milliseconds grace) {
    signal(SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + grace;
    while (!poll() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
    if (!poll()) {
      signal(SIGKILL);
      int status = 0;
      waitpid(pid_, &status, 0);
      status_ = status;
    }
  }
  bool succeeded() const { return status_ && WIFEXITED(*status_) && WEXITSTATUS(*status_) == 0; }
  std::string outcome() const {
    if (!status_) return "still running";
    if (WIFEXITED(*status_)) return "exit status " + std::to_string(WEXITSTATUS(*status_));
    return std::string("killed by signal ") + strsignal(WTERMSIG(*status_));
  }

 private:
  std::string name_;
  pid_t pid_ = -1;
  std::optional<int> status_;
};

fs::path siblingExecutable(const std::string& name) {
  const fs::path self = fs::read_symlink("/proc/self/exe");
  const fs::path exe = self.parent_path() / name;
  if (!fs::exists(exe)) throw std::runtime_error("cannot find " + name + " next to " + self.string());
  return exe;
}

constexpr const char* kRunDirectoryPrefix = "demfem-run-";
constexpr const char* kOwnerFile = "demfem.pid";

// Removes run directories of this user's earlier runs whose front end is gone (killed before it
// could remove them). A directory without an owner file may be a run starting up: it stays.
void removeStaleRunDirectories(const fs::path& parent) {
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(parent, ec)) {
    const std::string name = entry.path().filename().string();
    struct stat info {};
    if (name.rfind(kRunDirectoryPrefix, 0) != 0 || lstat(entry.path().c_str(), &info) != 0 || !S_ISDIR(info.st_mode) ||
        info.st_uid != getuid())
      continue;
    long pid = 0;
    std::ifstream(entry.path() / kOwnerFile) >> pid;
    if (pid > 0 && kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) fs::remove_all(entry.path(), ec);
  }
}

// The run's private directory, removed when the run ends.
class RunDirectory {
 public:
  RunDirectory() {
    const fs::path parent = fs::temp_directory_path();
    removeStaleRunDirectories(parent);
    std::string name = (parent / (std::string(kRunDirectoryPrefix) + "XXXXXX")).string();
    if (!mkdtemp(name.data()))  // mode 0700, a new directory or an error
      throw std::runtime_error("cannot create a private run directory in " + parent.string() + ": " + std::strerror(errno));
    path_ = name;
    std::ofstream owner(path_ / kOwnerFile);
    owner << getpid() << '\n';
    owner.close();
    if (!owner) {
      remove();
      throw std::runtime_error("cannot write " + (path_ / kOwnerFile).string());
    }
  }
  ~RunDirectory() { remove(); }
  RunDirectory(const RunDirectory&) = delete;
  RunDirectory& operator=(const RunDirectory&) = delete;
  const fs::path& path() const { return path_; }
  void remove() const {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }

 private:
  fs::path path_;
};

// Ends this process by `signal` (so the caller's shell sees how it ended). Raising it skips the
// destructors, so the run's directory is removed here first.
[[noreturn]] void endBySignal(int signal, const RunDirectory& work) {
  work.remove();
  std::signal(signal, SIG_DFL);
  std::raise(signal);
  std::abort();
}

void runLocal(const RunOptions& o, const std::string& json_target) {
  const study::Study study = cli::loadCheckedStudy(o.study_file);  // validate before starting anything
  if (study.kind == study::StudyKind::WeightDrop)
    throw InputError(o.study_file + ": a weight-drop study has no DEM side; run it with: demfem-fem weight-drop " + o.study_file);
  if (study.kind == study::StudyKind::ConePenetration) {  // no FEM side: the cones are pushed in this process
    CptOptions cpt;
    cpt.output_dir = o.output_dir.empty() ? study.output.directory.string() : o.output_dir;
    cpt.backend = o.backend;
    cpt.threads = o.threads;
    cpt.allow_unsettled_soil = o.allow_unsettled_soil;
    cpt.quiet = o.quiet;
    runConePenetration({o.study_file}, cpt, json_target);
    return;
  }
  const std::string& backend = o.backend.empty() ? study.dem.backend : o.backend;
  if (study::hasSoil(study.kind) && findBackend(backend).capabilities.simulates_soil) {
    // A soil already deposited is checked before anything starts (demfem-dem checks one it deposits).
    const fs::path soil = adapter::settledSoilFile(study, adapter::defaultSoilDirectory());
    if (fs::exists(soil)) requireSettled(adapter::readSettledSoil(soil, study), soil, o.allow_unsettled_soil);
  }
  const fs::path dem_exe = siblingExecutable("demfem-dem"), fem_exe = siblingExecutable("demfem-fem");
  const RunDirectory work;
  const std::string endpoint = "ipc://" + (work.path() / "dem.ipc").string();
  const fs::path endpoint_file = work.path() / "endpoint";

  std::signal(SIGINT, onForwardedSignal);
  std::signal(SIGTERM, onForwardedSignal);

  std::vector<std::string> dem_args{dem_exe.string(), "--study", o.study_file, "--bind", endpoint, "--endpoint-file",
                                    endpoint_file.string()};
  if (!o.backend.empty()) dem_args.insert(dem_args.end(), {"--backend", o.backend});
  if (o.threads > 0) dem_args.insert(dem_args.end(), {"--threads", std::to_string(o.threads)});
  if (o.allow_unsettled_soil) dem_args.push_back("--allow-unsettled-soil");
  if (!o.output_dir.empty()) dem_args.insert(dem_args.end(), {"--output", o.output_dir});
  if (o.checkpoint_every > 0 || o.resume) {
    // The DEM keeps its checkpoints next to the FEM's (fem/coupled_driver.hpp names them).
    const fs::path output = !o.output_dir.empty() ? fs::path(o.output_dir) : study.output.directory;
    dem_args.insert(dem_args.end(), {"--checkpoint-dir", (output / "checkpoint").string()});
  }
  Child dem("demfem-dem", dem_args);

  // The FEM client starts at once: its keypoint reduction overlaps the DEM's deposition, and it
  // connects when the DEM server has written its endpoint file.
  std::vector<std::string> fem_args{fem_exe.string(), "run", o.study_file, "--connect", endpoint, "--wait-for", endpoint_file.string()};
  if (!o.output_dir.empty()) fem_args.insert(fem_args.end(), {"--output", o.output_dir});
  if (o.steps > 0) fem_args.insert(fem_args.end(), {"--steps", std::to_string(o.steps)});
  if (o.checkpoint_every > 0) fem_args.insert(fem_args.end(), {"--checkpoint-every", std::to_string(o.checkpoint_every)});
  if (o.resume) fem_args.push_back("--resume");
  if (o.quiet) fem_args.push_back("--quiet");
  if (!json_target.empty()) fem_args.insert(fem_args.end(), {"--json", json_target});
  Child fem("demfem-fem", fem_args);

  // The DEM server binds after building its backend (deposition may take a while): wait for it.
  while (!fs::exists(endpoint_file)) {
    if (const int sig = g_forward_signal) {
      fem.stop(5s);
      dem.stop(5s);
      endBySignal(sig, work);
    }
    if (dem.poll()) {
      fem.stop(5s);
      throw std::runtime_error("demfem-dem stopped before serving (" + dem.outcome() + ")");
    }
    if (fem.poll()) {
      dem.stop(5s);
      throw std::runtime_error("demfem-fem stopped before the DEM served (" + fem.outcome() + "; see its message above)");
    }
    std::this_thread::sleep_for(20ms);
  }

  int forwarded = 0;
  for (;;) {
    if (const int sig = g_forward_signal.exchange(0)) {
      forwarded = sig;
      fem.signal(sig);  // the FEM client marks its outputs incomplete and exits
      dem.signal(sig);
    }
    const bool fem_done = fem.poll(), dem_done = dem.poll();
    if (fem_done && dem_done) break;
    if (fem_done && !fem.succeeded()) dem.stop(5s);          // nobody will shut the DEM down
    if (dem_done && !dem.succeeded() && !fem_done) fem.stop(10s);  // the FEM would wait for its timeout
    if (fem_done && fem.succeeded() && !dem_done) {
      // The client shut the server down; give it a moment to exit on its own.
      const auto deadline = std::chrono::steady_clock::now() + 10s;
      while (!dem.poll() && std::chrono::steady_clock::now() < deadline) std::this_thread::sleep_for(20ms);
      if (!dem.poll()) dem.stop(5s);
    }
    std::this_thread::sleep_for(20ms);
  }
  if (forwarded) endBySignal(forwarded, work);
  if (!fem.succeeded() || !dem.succeeded())
    throw std::runtime_error("coupled run failed: demfem-fem " + fem.outcome() + ", demfem-dem " + dem.outcome() +
                             " (see their messages above)");
}

}  // namespace

void addRunCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("run",
                                 "Run a coupled or DEM-only study locally: starts demfem-dem (the study's DEM backend) and "
                                 "demfem-fem, connected over ipc://");
  auto o = std::make_shared<RunOptions>();
  cmd->add_option("study", o->study_file, "Study file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--output,--out", o->output_dir, "Output directory; default: the study's output.directory");
  cmd->add_option("--backend", o->backend, "Override the study's DEM backend (builtin, liggghts, constant, harmonic, spring)");
  cmd->add_option("--steps", o->steps, "Stop after this many FEM steps (outputs then marked incomplete)")->check(CLI::PositiveNumber);
  cmd->add_option("--checkpoint-every", o->checkpoint_every, "Coupled checkpoint every N FEM steps")->check(CLI::PositiveNumber);
  cmd->add_option("--threads", o->threads, "threads of the built-in DEM; default: the study's dem.threads (the machine's cores)")
      ->check(CLI::PositiveNumber);
  cmd->add_flag("--resume", o->resume, "Resume from the checkpoint in the output directory");
  cmd->add_flag("--quiet", o->quiet, "No progress output");
  addAllowUnsettledSoilFlag(*cmd, o->allow_unsettled_soil);
  std::string& json = addJsonOption(*cmd);
  cmd->callback([o, &json] { runLocal(*o, json); });
}

}  // namespace demfem::cli
