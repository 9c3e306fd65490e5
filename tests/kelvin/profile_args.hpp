#pragma once
// The command line the Kelvin profiling programs (build_profile.cpp, query_profile.cpp) share:
// "--name value" pairs, --help, a required --cache-dir DIR and an --lx list; each adds its own.
#include <cstdio>
#include <functional>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace distlab::kelvin_profile {

// "0.05,0.02" -> {0.05, 0.02}.
inline std::vector<double> parse_list(const std::string& s) {
  std::vector<double> out;
  std::stringstream in(s);
  for (std::string item; std::getline(in, item, ',');) out.push_back(std::stod(item));
  return out;
}

// The program's own options: name ("--repeat") -> what its value sets.
using OptionHandlers = std::map<std::string, std::function<void(const std::string& value)>>;

// Fills cache_dir, lxs (left as given when absent) and the program's own options from argv.
// Returns -1 to go on, else the exit code: 0 after --help (usage printed), 2 (with a message on
// stderr) for an option without a value, an unknown option or a missing --cache-dir.
inline int parse_profile_args(int argc, char** argv, const char* usage, std::string& cache_dir,
                              std::vector<double>& lxs, const OptionHandlers& own) {
  for (int i = 1; i < argc; ++i) {
    const std::string k = argv[i];
    if (k == "--help") {
      std::puts(usage);
      return 0;
    }
    if (i + 1 >= argc) {
      std::fprintf(stderr, "option %s needs a value\n", k.c_str());
      return 2;
    }
    const std::string v = argv[++i];
    if (k == "--lx") {
      lxs = parse_list(v);
    } else if (k == "--cache-dir") {
      cache_dir = v;
    } else if (const auto it = own.find(k); it != own.end()) {
      it->second(v);
    } else {
      std::fprintf(stderr, "unknown option %s\n", k.c_str());
      return 2;
    }
  }
  if (cache_dir.empty()) {
    std::fputs("--cache-dir DIR is required (meshes are stored there once)\n", stderr);
    return 2;
  }
  return -1;
}

}  // namespace distlab::kelvin_profile
