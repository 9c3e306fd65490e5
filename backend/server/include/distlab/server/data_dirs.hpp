#pragma once
// Where the service's data directories (built-in assets, the front end) are found. One rule for
// all: a path given on the command line is taken as given (relative to the working directory) and
// must exist; without one, the environment variable, then the default relative to the working
// directory, then the default in the binary's directory or any directory above it.
#include <string>
#include <vector>

namespace distlab::server {

// The candidates in order: $env (when set), ./relative, then relative and share/distlab/installed
// (cmake --install's layout) in the binary's directory and above (/proc/self/exe).
std::vector<std::string> data_dir_candidates(const char* env, const std::string& relative, const std::string& installed);

// The first existing directory of data_dir_candidates, or of {given} when given is not empty;
// std::runtime_error naming option, the variable and the places looked at when there is none.
std::string find_data_dir(const std::string& option, const char* env, const std::string& relative,
                          const std::string& installed, const std::string& given = "");

// The prepared Kelvin objects' disk cache by default: $XDG_CACHE_HOME/distlab, else
// ~/.cache/distlab, else "" (none: a temporary directory for the service).
std::string default_cache_dir();

}  // namespace distlab::server
