// distlab: the command-line entry point. `distlab <command> [args]`; see `distlab help`.
#include <iostream>

#include "command.hpp"
#include "huge_page_heap.hpp"

namespace distlab::app {

std::map<std::string, Command>& commands() {
  static std::map<std::string, Command> table;
  return table;
}

}  // namespace distlab::app

namespace {

int usage(std::ostream& out) {
  out << "usage: distlab <command> [options]\n\ncommands:\n";
  for (const auto& [name, command] : distlab::app::commands())
    out << "  " << name << std::string(name.size() < 10 ? 10 - name.size() : 1, ' ')
        << command.summary << "\n";
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  distlab::app::use_huge_page_heap(argv);
  std::ios::sync_with_stdio(false);
  if (argc < 2) return usage(std::cerr);
  const std::string name = argv[1];
  if (name == "help" || name == "--help" || name == "-h") {
    usage(std::cout);
    return 0;
  }
  auto& table = distlab::app::commands();
  auto it = table.find(name);
  if (it == table.end()) {
    std::cerr << "distlab: unknown command '" << name << "'\n";
    return usage(std::cerr);
  }
  std::vector<std::string> args(argv + 2, argv + argc);
  try {
    return it->second.run(args, std::cin, std::cout, std::cerr);
  } catch (const std::exception& e) {
    std::cerr << "distlab " << name << ": internal error: " << e.what() << "\n";
    return 70;
  }
}
