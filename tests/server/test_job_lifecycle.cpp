// A job cancelled while it waits in the queue never runs its work; what that work would have
// ended ends with the job (JobManager::submit's `skipped`): a Kelvin object is "cancelled", not
// "preparing" for ever, and a rollout is "cancelled" with no record (409 no_record, not
// not_finished). One job thread, held by a long rollout, keeps the others queued.
#include <chrono>
#include <string>
#include <thread>

#include "server/server_fixture.hpp"

namespace distlab::test {
namespace {

json job_of(httplib::Client& c, const std::string& s, const std::string& id) { return get_json(c, s, "/api/jobs/" + id); }

void cancel(httplib::Client& c, const std::string& s, const std::string& id) {
  auto r = c.Post("/api/jobs/" + id + "/cancel", session_headers(s), "", "application/json");
  ASSERT_TRUE(r);
  ASSERT_EQ(r->status, 202) << r->body;
}

// Polls the job until it has ended (at most 120 s); returns its last state.
std::string wait_ended(httplib::Client& c, const std::string& s, const std::string& id) {
  std::string state;
  for (int i = 0; i < 1200; ++i) {
    state = job_of(c, s, id)["state"];
    if (state != "queued" && state != "running") break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return state;
}

TEST(JobLifecycle, WorkCancelledWhileQueuedEndsWithItsJob) {
  ServerProcess server({"--threads", "1"});
  httplib::Client c = server.client();
  const std::string s = new_session(c);
  // 150 s of simulated time: seconds of work on the one job thread.
  const json long_run = {{"scenario", "corridor"}, {"metric", "gap"}, {"params", {{"duration", 150}, {"record_pairs", false}}}};
  auto r = c.Post("/api/cbf/rollouts", session_headers(s), long_run.dump(), "application/json");
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string busy = body_json(r)["job"]["id"];
  for (int i = 0; i < 600 && job_of(c, s, busy)["state"] == "queued"; ++i) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  ASSERT_EQ(job_of(c, s, busy)["state"], "running");

  r = c.Post("/api/cbf/rollouts", session_headers(s), json{{"scenario", "corridor"}, {"params", {{"duration", 1}}}}.dump(), "application/json");
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string rollout = body_json(r)["job"]["id"];
  r = c.Post("/api/kelvin/objects", session_headers(s), json{{"asset", "cube"}, {"lx", 0.3}}.dump(), "application/json");
  ASSERT_EQ(r->status, 202) << r->body;
  const std::string object = body_json(r)["object"]["id"], object_job = body_json(r)["job"]["id"];
  ASSERT_EQ(job_of(c, s, rollout)["state"], "queued");
  ASSERT_EQ(job_of(c, s, object_job)["state"], "queued");

  cancel(c, s, rollout);
  cancel(c, s, object_job);
  cancel(c, s, busy);
  EXPECT_EQ(wait_ended(c, s, busy), "cancelled");
  EXPECT_EQ(wait_ended(c, s, rollout), "cancelled");
  EXPECT_EQ(wait_ended(c, s, object_job), "cancelled");

  const json o = get_json(c, s, "/api/kelvin/objects/" + object);
  EXPECT_EQ(o["state"], "cancelled") << o.dump();
  const json ro = get_json(c, s, "/api/cbf/rollouts/" + rollout);
  EXPECT_EQ(ro["state"], "cancelled") << ro.dump();
  EXPECT_EQ(ro["steps_done"], 0) << ro.dump();
  expect_error(c.Get("/api/cbf/rollouts/" + rollout + "/record", session_headers(s)), 409, "no_record");
  // The rollout that ran keeps the steps it made.
  EXPECT_EQ(get_json(c, s, "/api/cbf/rollouts/" + busy + "/record")["summary"]["cancelled"], true);
  EXPECT_EQ(server.stop(), 0) << "the server did not exit cleanly";
}

}  // namespace
}  // namespace distlab::test
