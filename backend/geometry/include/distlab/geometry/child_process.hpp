#pragma once
// A helper program run as a child process, for work this process must not risk (an untrusted
// file's parser, CGAL's parallel mesher): it starts with posix_spawn (the callers are
// multithreaded, so only exec may follow a fork), sends its answer on a pipe and is killed and
// reaped by the parent whatever happens.
#include <sys/types.h>

#include <functional>
#include <string>
#include <vector>

namespace distlab {

class ChildProcess {
 public:
  // Runs exe with args (args[0] is the child's argv[0]). Its stdout is a pipe read by read(), its
  // stdin /dev/null, its stderr /dev/null when quiet (parsers chatter) or this process's, and
  // input >= 0 becomes its fd 3; no other descriptor is passed. SIGPIPE, SIGXCPU, SIGTERM and SIGINT
  // take their default actions there, nothing is blocked. Throws std::runtime_error if it cannot start.
  ChildProcess(const std::string& exe, const std::vector<std::string>& args, int input = -1, bool quiet = true);
  ~ChildProcess();  // kills and reaps a child still running
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  enum class End { eof,
                   deadline,
                   cap,
                   stopped };
  // Appends the child's stdout to data until it closes it (eof), `seconds` pass (infinity: no
  // limit), data would pass
  // cap bytes, or tick returns false (stopped). tick runs after every chunk read and at least
  // every 100 ms, so a caller can consume data as it comes and notice a cancellation.
  End read(std::string& data, double seconds, std::size_t cap, const std::function<bool()>& tick = {});

  void kill();  // SIGKILL; the exit status then says signalled by SIGKILL
  // Waits for the child's end and returns its waitpid status (WIFEXITED, WTERMSIG, ...).
  int wait();

 private:
  pid_t pid_ = -1;
  int out_ = -1;
  bool reaped_ = false;
  int status_ = 0;
};

// Bytes for a child's input as an anonymous in-memory file (memfd): nothing in any directory, so
// nothing is left behind if this process dies. Pass fd() as ChildProcess's input.
class MemoryFile {
 public:
  MemoryFile(const std::string& name, const std::string& bytes);  // std::runtime_error if it cannot
  ~MemoryFile();
  MemoryFile(const MemoryFile&) = delete;
  MemoryFile& operator=(const MemoryFile&) = delete;
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

}  // namespace distlab
