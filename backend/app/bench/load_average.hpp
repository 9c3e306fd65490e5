#pragma once
// The machine's load (/proc/loadavg: 1, 5 and 15 minutes), printed by every benchmark before and
// after its run: compare ratios within one run, absolute times only at load < 1.
#include <fstream>
#include <string>

namespace distlab::bench {

inline std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

}  // namespace distlab::bench
