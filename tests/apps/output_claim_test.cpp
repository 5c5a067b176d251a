// The analysis commands claim their output directory before the first write: a second command on
// the same directory fails at once naming the holder, and a killed writer's temporaries are
// removed while a run's resumable files stay (docs/reliability.md, "One writer per output directory").
#include "process.hpp"

#include "demfem/adapter/output_files.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

using namespace demfem::testing;

TEST_CASE("evaluate refuses an output directory another process holds, and writes nothing there", "[apps]") {
  const fs::path dir = freshDir("claim-held");
  {
    const demfem::adapter::DirectoryLock held(dir / "out");  // this test process is the other writer
    Process p({app("demfem"), "evaluate", (sourceDir() / "examples" / "data" / "measured").string(), "--out", (dir / "out").string(),
               "--no-plots"},
              dir / "evaluate");
    const int status = p.wait(std::chrono::seconds(120));
    CHECK(WIFEXITED(status));
    CHECK(WEXITSTATUS(status) != 0);
    CHECK(p.err().find("in use") != std::string::npos);
    CHECK(p.err().find(std::to_string(::getpid())) != std::string::npos);
    CHECK_FALSE(fs::exists(dir / "out" / "report.md"));
  }
  // Released: the same command succeeds.
  Process again({app("demfem"), "evaluate", (sourceDir() / "examples" / "data" / "measured").string(), "--out", (dir / "out").string(),
                 "--no-plots"},
                dir / "again");
  CHECK(exitedOk(again.wait(std::chrono::seconds(120))));
  CHECK(fs::exists(dir / "out" / "report.md"));
  fs::remove_all(dir);
}

TEST_CASE("a claimed output directory loses a killed writer's temporaries and keeps a run's resumable files", "[apps]") {
  const fs::path dir = freshDir("claim-stale");
  fs::create_directories(dir / "out" / "plots");
  std::ofstream(dir / "out" / "report.md.999999.partial") << "half a report";
  std::ofstream(dir / "out" / "plots" / "a.svg.999999-2.partial") << "<svg";
  std::ofstream(dir / "out" / "sensors.csv.partial") << "t,force\n";
  Process p({app("demfem"), "evaluate", (sourceDir() / "examples" / "data" / "measured").string(), "--out", (dir / "out").string(),
             "--no-plots"},
            dir / "evaluate");
  INFO(p.err());
  CHECK(exitedOk(p.wait(std::chrono::seconds(120))));
  CHECK_FALSE(fs::exists(dir / "out" / "report.md.999999.partial"));
  CHECK_FALSE(fs::exists(dir / "out" / "plots" / "a.svg.999999-2.partial"));
  CHECK(fs::exists(dir / "out" / "sensors.csv.partial"));
  fs::remove_all(dir);
}

TEST_CASE("every command that writes a directory takes both --out and --output", "[apps]") {
  // One flag name for users whichever command they run (it was --out, --output or --dir).
  const fs::path dir = freshDir("out-flags");
  for (const std::vector<std::string>& command :
       {std::vector<std::string>{"demfem", "run"}, {"demfem", "evaluate"}, {"demfem", "compare"}, {"demfem", "calibrate"},
        {"demfem", "diagnose"}, {"demfem", "cpt"}, {"demfem", "soil-motion"}, {"demfem", "campaign"}, {"demfem-fem", "run"},
        {"demfem-dem"}}) {
    std::vector<std::string> args{app(command.front())};
    args.insert(args.end(), command.begin() + 1, command.end());
    args.push_back("--help");
    Process p(args, dir / "help");
    INFO(command.front() << (command.size() > 1 ? " " + command[1] : std::string()) << ": " << p.out());
    CHECK(exitedOk(p.wait(std::chrono::seconds(60))));
    const std::string help = p.out();
    CHECK((help.find("--out,") != std::string::npos || help.find(",--out ") != std::string::npos));  // not only --output
    CHECK(help.find("--output") != std::string::npos);
  }
  fs::remove_all(dir);
}
