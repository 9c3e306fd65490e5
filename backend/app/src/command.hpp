#pragma once
// Subcommands of the `distlab` executable register themselves here (one file per command).
#include <functional>
#include <iosfwd>
#include <map>
#include <string>
#include <vector>

namespace distlab::app {

struct Command {
  std::string summary;
  // args excludes the program and command names; returns the process exit code.
  std::function<int(const std::vector<std::string>& args, std::istream& in, std::ostream& out,
                    std::ostream& err)>
      run;
};

std::map<std::string, Command>& commands();

struct RegisterCommand {
  RegisterCommand(const std::string& name, Command command) {
    commands().emplace(name, std::move(command));
  }
};

}  // namespace distlab::app
