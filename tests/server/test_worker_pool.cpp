// The compute pool: its threads run on_start before any task, and warm_thread_heap leaves a new
// thread's malloc arena with touched pages, so a frame's first allocations do not page-fault.
#include <gtest/gtest.h>
#include <sys/resource.h>

#include <atomic>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <set>
#include <thread>

#include "distlab/server/worker_pool.hpp"

using distlab::server::warm_thread_heap;
using distlab::server::WorkerPool;

namespace {

constexpr std::size_t kBlock = std::size_t{4} << 20;

long thread_minor_faults() {
  rusage u{};
  getrusage(RUSAGE_THREAD, &u);
  return u.ru_minflt;
}

// Minor page faults of this thread while it allocates, touches and frees kBlock.
long faults_of_a_block() {
  const long before = thread_minor_faults();
  void* p = std::malloc(kBlock);
  std::memset(p, 2, kBlock);
  asm volatile(""
               :
               : "r"(p)
               : "memory");
  std::free(p);
  return thread_minor_faults() - before;
}

}  // namespace

// First in this file: a new thread must get a new arena (no arena freed by an earlier thread).
TEST(WorkerPool, AWarmedThreadAllocatesWithoutPageFaults) {
#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
  GTEST_SKIP() << "the sanitizer's allocator is not glibc's malloc";
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer) || __has_feature(memory_sanitizer)
  GTEST_SKIP() << "the sanitizer's allocator is not glibc's malloc";
#endif
#endif
  const long pages = static_cast<long>(kBlock / 4096);
  long cold = 0, warm = 0;
  std::thread([&] { cold = faults_of_a_block(); }).join();
  std::thread([&] {
    warm_thread_heap(2 * kBlock);
    warm = faults_of_a_block();
  }).join();
  EXPECT_GE(cold, pages / 2) << "a new thread's first block should fault its pages in";
  EXPECT_LT(warm, pages / 16) << "after warm_thread_heap the pages should already be there";
}

TEST(WorkerPool, EveryThreadRunsItsStartBeforeAnyTask) {
  std::mutex m;
  std::set<std::thread::id> started;
  std::atomic<int> tasks_before_start{0}, done{0};
  {
    WorkerPool pool(3, [&] {
      std::lock_guard lock(m);
      started.insert(std::this_thread::get_id());
    });
    for (int i = 0; i < 50; ++i)
      ASSERT_TRUE(pool.post([&] {
        {
          std::lock_guard lock(m);
          if (started.count(std::this_thread::get_id()) == 0) ++tasks_before_start;
        }
        ++done;
      }));
    pool.stop();
  }
  EXPECT_EQ(started.size(), 3u);
  EXPECT_EQ(tasks_before_start.load(), 0);
  EXPECT_EQ(done.load(), 50);
}
