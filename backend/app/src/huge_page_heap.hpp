#pragma once
#include <unistd.h>

#include <cstdlib>
#include <string>
#include <string_view>

namespace distlab::app {

// glibc's heap on transparent huge pages (the tunable glibc.malloc.hugetlb=1): the mesher's
// triangulation, the factorization and the field's arrays then fault in 2 MB pages, not 4 KB ones;
// on a VM a fault costs a hypervisor exit. The cube at l_x 0.02 in the service: decomp 14.2-14.7
// -> 8.5-10.3 s, build 0.9 -> 0.4 s, the store's write 5.3 -> 3.1 s; at l_x 0.03 in the CLI, mesh
// 5.2-5.7 -> 3.9-5.0 s. The same mesh and field bit for bit (one mesh thread).
// glibc reads its tunables only as a process starts, so this one re-executes itself once with the
// setting added; its children inherit it. A setting of the user's own is kept as it is;
// DISTLAB_HUGE_PAGES=0 leaves it out, as it leaves out the arrays' advice (kelvin's huge_pages.hpp).
// The CLI and the benchmarks call it first thing in main (the benchmarks' baselines, in the same
// process or its children, get the same heap).
inline void use_huge_page_heap(char** argv) {
  const char* advice = std::getenv("DISTLAB_HUGE_PAGES");
  if (advice != nullptr && std::string_view(advice) == "0") return;
  const char* given = std::getenv("GLIBC_TUNABLES");
  std::string tunables = given != nullptr ? given : "";
  if (tunables.find("glibc.malloc.hugetlb") != std::string::npos) return;
  tunables += std::string(tunables.empty() ? "" : ":") + "glibc.malloc.hugetlb=1";
  if (::setenv("GLIBC_TUNABLES", tunables.c_str(), 1) != 0) return;
  ::execv("/proc/self/exe", argv);
  // Not re-executed (no /proc): run as started, and leave the environment as it was.
  if (given != nullptr)
    ::setenv("GLIBC_TUNABLES", tunables.substr(0, tunables.rfind(':')).c_str(), 1);
  else
    ::unsetenv("GLIBC_TUNABLES");
}

}  // namespace distlab::app
