// A helper program run as a child process (child_process.hpp).
#include "distlab/geometry/child_process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <stdexcept>

extern char** environ;

namespace distlab {

ChildProcess::ChildProcess(const std::string& exe, const std::vector<std::string>& args, int input, bool quiet) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("cannot create a pipe for " + exe);
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_adddup2(&actions, fds[1], 1);  // dup2 clears close-on-exec
  ::posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  if (quiet) ::posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);
  if (input >= 0) ::posix_spawn_file_actions_adddup2(&actions, input, 3);
  ::posix_spawn_file_actions_addclosefrom_np(&actions, input >= 0 ? 4 : 3);  // no listening socket or session file
  ::posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int s : {SIGPIPE, SIGXCPU, SIGTERM, SIGINT}) sigaddset(&defaults, s);
  ::posix_spawnattr_setsigmask(&attr, &none);
  ::posix_spawnattr_setsigdefault(&attr, &defaults);
  ::posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  std::vector<std::string> argv_strings = args;
  std::vector<char*> argv;
  argv.reserve(argv_strings.size() + 1);
  for (auto& a : argv_strings) argv.push_back(a.data());
  argv.push_back(nullptr);
  const int spawned = ::posix_spawn(&pid_, exe.c_str(), &actions, &attr, argv.data(), environ);
  ::posix_spawn_file_actions_destroy(&actions);
  ::posix_spawnattr_destroy(&attr);
  ::close(fds[1]);
  if (spawned != 0) {
    ::close(fds[0]);
    throw std::runtime_error("cannot start " + exe + ": " + std::strerror(spawned));
  }
  out_ = fds[0];
}

ChildProcess::~ChildProcess() {
  if (!reaped_) {
    kill();
    wait();
  }
  if (out_ >= 0) ::close(out_);
}

ChildProcess::End ChildProcess::read(std::string& data, double seconds, std::size_t cap, const std::function<bool()>& tick) {
  const bool forever = !(seconds < 1e9);  // infinity: no time_point holds it
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(forever ? 0.0 : seconds);
  char buffer[1 << 16];
  for (;;) {
    if (tick && !tick()) return End::stopped;
    long long wait_ms = 100;
    if (!forever) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return End::deadline;
      wait_ms = std::min<long long>(left.count(), wait_ms);
    }
    pollfd p{out_, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(wait_ms));
    if (ready < 0 && errno != EINTR) return End::eof;  // judged by what arrived and the exit status
    if (ready <= 0) continue;
    const ssize_t n = ::read(out_, buffer, sizeof buffer);
    if (n == 0) return End::eof;
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return End::eof;
    }
    if (data.size() + static_cast<std::size_t>(n) > cap) return End::cap;
    data.append(buffer, static_cast<std::size_t>(n));
  }
}

void ChildProcess::kill() {
  if (!reaped_) ::kill(pid_, SIGKILL);
}

int ChildProcess::wait() {
  if (!reaped_) {
    while (::waitpid(pid_, &status_, 0) < 0 && errno == EINTR) {
    }
    reaped_ = true;
  }
  return status_;
}

MemoryFile::MemoryFile(const std::string& name, const std::string& bytes) : fd_(::memfd_create(name.c_str(), MFD_CLOEXEC)) {
  if (fd_ < 0) throw std::runtime_error(std::string("cannot create an in-memory file: ") + std::strerror(errno));
  for (std::size_t at = 0; at < bytes.size();) {
    const ssize_t n = ::write(fd_, bytes.data() + at, bytes.size() - at);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int error = errno;
      ::close(fd_);
      throw std::runtime_error(std::string("cannot write an in-memory file: ") + std::strerror(error));
    }
    at += static_cast<std::size_t>(n);
  }
}

MemoryFile::~MemoryFile() { ::close(fd_); }

}  // namespace distlab
