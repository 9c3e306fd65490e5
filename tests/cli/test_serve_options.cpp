// The service's command lines: `distlab serve` finds --assets and --web by one rule and says
// clearly when one is missing (exit 2, before listening); `distlab-bench-server --help` prints its
// usage without connecting anywhere.
#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "cli/run_process.hpp"

namespace {

struct Outcome {
  int code = -1;
  std::string out, err;
};

std::string slurp(const std::string& path) {
  std::ifstream f(path);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

// Runs exe with args, stdin from /dev/null, in the directory cwd; stops it after 20 s at most.
Outcome run(const std::string& exe, std::vector<std::string> args, const std::string& cwd = "/") {
  const std::string out = "/tmp/distlab_serve_opts_out_" + std::to_string(::getpid());
  const std::string err = "/tmp/distlab_serve_opts_err_" + std::to_string(::getpid());
  std::vector<std::string> full = {"/usr/bin/timeout", "20", exe};
  full.insert(full.end(), args.begin(), args.end());
  Outcome r;
  r.code = distlab::test::run_process(full, "/dev/null", out, err, cwd.c_str());
  r.out = slurp(out);
  r.err = slurp(err);
  std::remove(out.c_str());
  std::remove(err.c_str());
  return r;
}

const std::string kAssets = std::string(DISTLAB_SOURCE_DIR) + "/assets";

TEST(ServeOptions, MissingWebDirectoryIsAClearErrorBeforeListening) {
  const Outcome r = run(DISTLAB_EXE, {"serve", "--port", "0", "--assets", kAssets, "--web", "no-such-front-end"});
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--web no-such-front-end: no such directory"), std::string::npos) << r.err;
  EXPECT_EQ(r.out.find("listening"), std::string::npos) << r.out;
}

TEST(ServeOptions, MissingAssetsDirectoryIsAClearErrorBeforeListening) {
  const Outcome r = run(DISTLAB_EXE, {"serve", "--port", "0", "--assets", "no-such-assets", "--web", kAssets});
  EXPECT_EQ(r.code, 2) << r.out << r.err;
  EXPECT_NE(r.err.find("--assets no-such-assets: no such directory"), std::string::npos) << r.err;
}

// Both options are resolved against the working directory, by the same rule.
TEST(ServeOptions, RelativeWebAndAssetsAreResolvedAlike) {
  // From the source tree, "assets" exists and "assets/scenarios" too; from / neither does.
  const Outcome found = run(DISTLAB_EXE, {"serve", "--assets", "assets", "--web", "assets/scenarios", "--port", "70000"},
                            DISTLAB_SOURCE_DIR);
  EXPECT_EQ(found.code, 2);
  EXPECT_NE(found.err.find("--port must be"), std::string::npos) << found.err;  // checked after both directories
  const Outcome missing = run(DISTLAB_EXE, {"serve", "--assets", "assets", "--web", "assets/scenarios", "--port", "70000"}, "/");
  EXPECT_EQ(missing.code, 2);
  EXPECT_NE(missing.err.find("--assets assets: no such directory"), std::string::npos) << missing.err;
}

TEST(BenchServer, HelpPrintsUsageWithoutAServer) {
  const Outcome r = run(DISTLAB_BENCH_SERVER_EXE, {"--help"});
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_NE(r.out.find("usage: distlab-bench-server"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("--port"), std::string::npos);
  const Outcome bad = run(DISTLAB_BENCH_SERVER_EXE, {"--frobnicate"});
  EXPECT_EQ(bad.code, 2);
  EXPECT_NE(bad.err.find("usage:"), std::string::npos) << bad.err;
}

}  // namespace
