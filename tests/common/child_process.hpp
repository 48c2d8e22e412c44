#pragma once
// Child processes for the tests that run `regolith` (or a browser, or a second DDS participant)
// as a separate program: the one spawn / wait / kill helper of the test suite (header-only, on
// every test target's include path, like temp_dir.hpp).
//
//   namespace rt = regolith::testing;
//   const pid_t pid = rt::spawn({REGOLITH_EXE, "run", "--duration", "2"}, dir / "run.txt");
//   ASSERT_GT(pid, 0);                                      // stderr went to run.txt.err
//   EXPECT_EQ(rt::wait_exit(pid, std::chrono::seconds(60)), 0) << rt::read_file(dir / "run.txt.err");
//   (read_file: temp_dir.hpp)
//
// Waiting for another program is wall-clock time by nature; the tests keep it to the child's own
// run and bound it with a timeout, after which the child is killed, never left behind.
#include <chrono>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

extern char** environ;

namespace regolith::testing {

/// Where a spawned child's standard error goes.
enum class Stderr {
  kBeside,  ///< its own file, OUT.err beside the stdout file OUT
  kSame,    ///< the stdout file, interleaved
};

struct SpawnOptions {
  Stderr err = Stderr::kBeside;
  /// The child leads a process group of its own, so that the helpers it starts (a browser's
  /// zygote and services) can be ended with it: kill_group().
  bool own_process_group = false;
};

/// Starts the program args[0] (a path, not searched in PATH) with `args`, standard output into
/// `out` (created or truncated) and standard error as `opt.err` says. The child's pid, or -1 when
/// it could not be started.
inline pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& out, SpawnOptions opt = {}) {
  if (args.empty()) return -1;
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  const std::string err = out.string() + ".err";
  if (opt.err == Stderr::kSame)
    posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
  else
    posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, err.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawnattr_t attr;
  posix_spawnattr_init(&attr);
  if (opt.own_process_group) {
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP);
    posix_spawnattr_setpgroup(&attr, 0);
  }
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &fa, &attr, argv.data(), environ);
  posix_spawnattr_destroy(&attr);
  posix_spawn_file_actions_destroy(&fa);
  return rc == 0 ? pid : -1;
}

/// A waited child's exit status as a shell reports it: its exit code, or 128 + the signal that
/// ended it.
inline int exit_status(int wait_status) {
  return WIFEXITED(wait_status) ? WEXITSTATUS(wait_status) : 128 + WTERMSIG(wait_status);
}

/// What wait_exit(pid, timeout) returns for a child still running at the timeout.
inline constexpr int kTimedOut = -2;

/// Waits for the child `pid` to end: its exit_status(), or -1 when `pid` is not a child of ours.
inline int wait_exit(pid_t pid) {
  int status = 0;
  return waitpid(pid, &status, 0) == pid ? exit_status(status) : -1;
}

/// Waits up to `timeout` for the child `pid` to end: its exit_status(); after the timeout the
/// child is killed (SIGKILL) and reaped, and the result is kTimedOut.
inline int wait_exit(pid_t pid, std::chrono::milliseconds timeout) {
  const auto end = std::chrono::steady_clock::now() + timeout;
  int status = 0;
  while (true) {
    const pid_t r = waitpid(pid, &status, WNOHANG);
    if (r == pid) return exit_status(status);
    if (r < 0) return -1;
    if (std::chrono::steady_clock::now() >= end) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return kTimedOut;
}

/// Ends a child spawned with `own_process_group` and every process of its group: SIGTERM to the
/// group, up to `grace` for the leader to exit, SIGKILL to whatever outlived it, the leader
/// reaped, and then up to 5 s until the group is empty (a killed helper may still be exiting).
inline void kill_group(pid_t pid, std::chrono::milliseconds grace) {
  kill(-pid, SIGTERM);
  int status = 0;
  const auto end = std::chrono::steady_clock::now() + grace;
  while (waitpid(pid, &status, WNOHANG) != pid && std::chrono::steady_clock::now() < end)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  kill(-pid, SIGKILL);  // ESRCH when none is left
  waitpid(pid, &status, 0);
  for (int i = 0; i < 250 && kill(-pid, 0) == 0; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(20));
}

}  // namespace regolith::testing
