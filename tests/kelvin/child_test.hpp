#pragma once
// This test program run again as a child process with one test selected, for tests that need a
// second process (the field store's) or must outlive a crash of the code they test: CGAL 5.5's
// parallel refinement crashes its process about once in 1,000 small meshings (upstream races,
// kelvin/isolated_mesher.hpp), and a test of it in this process would crash with it.
#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <string>
#include <vector>

namespace distlab::kelvin::testing {

// Starts the test `name` (Suite.Test) of this program with `vars` added to the environment; its
// stdout (and stderr, if `output` is given) goes to `output`, else stdout to /dev/null. -1 if it
// could not start.
inline pid_t spawn_test(const std::string& name, const std::map<std::string, std::string>& vars,
                        const std::string& output = "") {
  std::vector<std::string> strings;
  for (char** e = environ; *e != nullptr; ++e) strings.emplace_back(*e);
  for (const auto& [k, v] : vars) strings.push_back(k + "=" + v);
  std::vector<char*> envp;
  for (auto& s : strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::string exe = std::filesystem::read_symlink("/proc/self/exe").string(), filter = "--gtest_filter=" + name;
  char* argv[] = {exe.data(), filter.data(), nullptr};
  posix_spawn_file_actions_t fa;
  posix_spawn_file_actions_init(&fa);
  if (output.empty()) {
    posix_spawn_file_actions_addopen(&fa, 1, "/dev/null", O_WRONLY, 0);
  } else {
    posix_spawn_file_actions_addopen(&fa, 1, output.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0600);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
  }
  pid_t pid = 0;
  const int r = posix_spawn(&pid, exe.c_str(), &fa, nullptr, argv, envp.data());
  posix_spawn_file_actions_destroy(&fa);
  return r == 0 ? pid : -1;
}

// The child's exit code, or 128 + the signal that ended it; -1 if there is no such child.
inline int wait_test(pid_t pid) {
  int status = 0;
  if (pid <= 0 || ::waitpid(pid, &status, 0) != pid) return -1;
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

constexpr char kChildTestVariable[] = "DISTLAB_CHILD_TEST";

// In the child run by run_test_in_child (the body's test skips itself elsewhere).
inline bool is_child_test(const std::string& name) {
  const char* v = std::getenv(kChildTestVariable);
  return v != nullptr && name == v;
}

// Runs the test `name` in a child: its failures fail this test, with its output. A child killed
// by a signal is run again, up to `attempts` children (all crashed: a failure); each crash is
// printed, so a crash that is not rare shows.
inline void run_test_in_child(const std::string& name, int attempts = 3) {
  const std::string output = (std::filesystem::temp_directory_path() /
                              ("distlab_child_test_" + std::to_string(::getpid()) + ".txt"))
                                 .string();
  std::string crashes;
  for (int attempt = 1; attempt <= attempts; ++attempt) {
    const int status = wait_test(spawn_test(name, {{kChildTestVariable, name}}, output));
    std::ifstream in(output);
    const std::string printed((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::filesystem::remove(output);
    if (status == 0) {
      if (printed.find("[  PASSED  ] 1 test") == std::string::npos) ADD_FAILURE() << name << " did not run:\n"
                                                                                  << printed;
      if (!crashes.empty()) std::cerr << crashes;  // visible in the test's log, not a failure
      return;
    }
    if (status <= 128) {
      ADD_FAILURE() << name << " failed in its child (exit " << status << "):\n"
                    << printed;
      return;
    }
    crashes += name + ": child " + std::to_string(attempt) + " killed by signal " + std::to_string(status - 128) + "\n";
  }
  ADD_FAILURE() << "every child crashed:\n"
                << crashes;
}

}  // namespace distlab::kelvin::testing
