#pragma once
// A preparation's stages and their shares of its time (issue 38 goal 3): the overall fraction of
// a preparation from Progress's (stage, fraction) reports, each stage weighed by its share (the
// server: its measured seconds per vertex of that stage for the sizing meshed), and the seconds
// each stage took, timed from the same reports (what the server measures the shares from).
#include <array>
#include <chrono>
#include <cstddef>
#include <mutex>
#include <string>

namespace distlab::kelvin {

// The stages that take a preparation's time, in the order they run (Progress's stage names):
// "load" is the checks and the centre's search, "mesh" includes "invert" (as Stats::t_mesh does),
// "cache" is the store's write (from fraction 0.5; below, its look-up before meshing), "response"
// the boundary response a server builds. "wait" (another process prepares the field) and the
// stages of other work ("repair", "simplify") have no share.
inline constexpr std::size_t kPrepareStageCount = 6;
inline constexpr std::array<const char*, kPrepareStageCount> kPrepareStages = {"load", "mesh", "build", "decomp", "cache", "response"};
using StageSeconds = std::array<double, kPrepareStageCount>;

// The index of a report's stage in kPrepareStages, or −1 (no share).
int prepare_stage_index(const std::string& stage, double fraction);

// How each stage's seconds grow with the field's vertices n: as n^exponent. Linear but for the
// factorization (CHOLMOD's factor of a 3-D mesh: n^1.5; the issue 38 table: 3.3× the vertices,
// 6.2× t_decomp) and the boundary response (a solve against that factor per boundary vertex,
// n^(2/3) of them: about n^2; the cube at l_x 0.05 against the wrench at 0.005, 4.6× the
// vertices: 17–24× the seconds).
inline constexpr StageSeconds kStageSizeExponents = {1, 1, 1, 1.5, 1, 2};

// The seconds of each stage at `vertices` field vertices before any is measured (the Python
// package's shares, the server's before its first preparation of the sizing): for eq. 23
// (grading 0) and the graded sizing (grading > 0), whose meshing costs about twice per vertex.
// Medians of preparations in the service at load < 1 (stages.cpp; 2-core machine, issue 38 goal 3).
// Meshing on mesh_threads threads divides the mesh stage by mesh_speedup(mesh_threads).
StageSeconds typical_stage_seconds(double grading, double vertices, int mesh_threads = 1);

// The parallel refinement's speed-up on `threads` threads against one: 1 + kParallelMeshGain per
// added thread. The cube at l_x 0.02, graded, on two threads in the child process: 17.49 → 10.49
// s (distlab-bench-kelvin --mesher) and 19.08 → 11.43 s in the service, 1.67× both.
inline constexpr double kParallelMeshGain = 0.67;
inline double mesh_speedup(int threads) { return 1 + kParallelMeshGain * (threads > 1 ? threads - 1 : 0); }

// Thread-safe.
class StageProgress {
 public:
  // shares: any non-negative weights (predicted seconds of each stage); all zero (or not finite)
  // weighs the stages equally.
  explicit StageProgress(const StageSeconds& shares);
  // The overall fraction after the report (stage, fraction): Σ share × the stage's fraction over
  // Σ share, a stage counting as complete once a later stage reports progress (a stage that does
  // not run, the meshing of a field loaded from the store, counts complete then). In [0, 1] and
  // never below an earlier answer. Reports without a share leave it as it is.
  double report(const std::string& stage, double fraction);
  double overall() const;
  // Closes the stage being timed: its time runs from its first report to the next report of
  // another stage (or finish). Call when the preparation ends.
  void finish();
  // The seconds each stage has taken so far (kPrepareStages order).
  StageSeconds seconds() const;

 private:
  mutable std::mutex mutex_;  // reports may come from the work's threads
  StageSeconds shares_{}, done_{}, seconds_{};
  int timed_ = -1;  // stage being timed; −1: none
  std::chrono::steady_clock::time_point since_;
  double overall_ = 0;
};

}  // namespace distlab::kelvin
