// Test helper without Catch (benchmarks use it too): start an executable with posix_spawn, its
// standard output and error written to files.
#pragma once

#include <fcntl.h>
#include <spawn.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

extern char** environ;

namespace demfem::support {

// Starts `args` (args[0] a path) with stdout to `out` and stderr to `err`; returns its pid. Throws
// std::runtime_error when it cannot start.
inline pid_t spawnLogged(std::vector<std::string> args, const std::filesystem::path& out, const std::filesystem::path& err) {
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_addopen(&actions, 2, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  std::vector<char*> argv;
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) throw std::runtime_error(std::string("cannot start ") + argv[0]);
  return pid;
}

}  // namespace demfem::support
