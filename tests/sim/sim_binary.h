// Running the restir-sim binary from a test, as a user would: its exit status, whether a signal ended it (a
// crash), what it printed, and its peak memory.
#pragma once

#include <spawn.h>
#include <sys/resource.h>
#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

extern char** environ;

namespace restir::test {

// ctest passes the binary's path; run by hand, the binary sits beside the test executable.
inline std::string SimBinary() {
  if (const char* bin = std::getenv("RESTIR_SIM_BIN")) return bin;
  return (std::filesystem::read_symlink("/proc/self/exe").parent_path() / "restir-sim").string();
}

struct ShellResult {
  bool exited = false;   // false: a signal ended it (a crash, or a limit such as RLIMIT_FSIZE)
  int status = -1;       // the exit status when it exited; -1 otherwise
  std::string output;    // stdout and stderr, interleaved
  double peakBytes = 0;  // peak resident memory of the command's processes (RUSAGE_CHILDREN's maximum)
};

// Runs `command` with /bin/sh, output captured (append 2>&1 to capture stderr). peakBytes is the largest resident
// set of any child this process has waited for so far, so measure one command per fresh process when it matters.
inline ShellResult Shell(const std::string& command) {
  ShellResult r;
  FILE* p = popen(command.c_str(), "r");
  if (!p) return r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), p)) r.output += buf.data();
  const int st = pclose(p);
  r.exited = WIFEXITED(st);
  r.status = r.exited ? WEXITSTATUS(st) : -1;
  return r;
}

// restir-sim with `args` (a shell word list), stderr captured with stdout.
inline ShellResult RunSim(const std::string& args) { return Shell(SimBinary() + " " + args + " 2>&1"); }

// restir-sim's argv for `args`: the strings are kept in `storage`.
inline std::vector<char*> SimArgv(const std::vector<std::string>& args, std::vector<std::string>& storage) {
  storage = {SimBinary()};
  storage.insert(storage.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : storage) argv.push_back(a.data());
  argv.push_back(nullptr);
  return argv;
}

// restir-sim with `args` as its argv in a child of its own, stdout and stderr to /dev/null, measured alone
// (wait4's rusage is the child's own, unlike RUSAGE_CHILDREN).
inline ShellResult RunSimMeasured(const std::vector<std::string>& args) {
  std::vector<std::string> storage;
  std::vector<char*> argv = SimArgv(args, storage);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, "/dev/null", O_WRONLY, 0);
  posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  pid_t pid = -1;
  ShellResult r;
  const int spawned = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return r;
  int st = 0;
  struct rusage usage {};
  if (wait4(pid, &st, 0, &usage) != pid) return r;
  r.exited = WIFEXITED(st);
  r.status = r.exited ? WEXITSTATUS(st) : -1;
  r.peakBytes = double(usage.ru_maxrss) * 1024.0;  // ru_maxrss is in KiB on Linux
  return r;
}

// Starts restir-sim with `args` without waiting (processes that must run at once); its stdout and stderr go to
// `log`. The pid, or -1.
inline pid_t SpawnSim(const std::vector<std::string>& args, const std::string& log) {
  std::vector<std::string> storage;
  std::vector<char*> argv = SimArgv(args, storage);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int r = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return r == 0 ? pid : -1;
}

// Waits for a SpawnSim child: its exit status, or -1 when a signal ended it.
inline int WaitSim(pid_t pid) {
  int st = 0;
  if (waitpid(pid, &st, 0) != pid || !WIFEXITED(st)) return -1;
  return WEXITSTATUS(st);
}

}  // namespace restir::test
