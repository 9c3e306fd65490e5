#pragma once
// The one lifecycle of the service's long work: a job, the Kelvin object it prepares, a CBF
// rollout and a sweep each go queued → running → succeeded | failed | cancelled. A feature's codec
// writes it in its API's own words (a Kelvin object "preparing" / "ready", a rollout "finished"),
// which the API keeps; the states and their order are these.
namespace distlab::server {

enum class Lifecycle { queued,
                       running,
                       succeeded,
                       failed,
                       cancelled };

// "queued", "running", "succeeded", "failed", "cancelled" (the jobs' words).
const char* to_string(Lifecycle s);

// succeeded, failed or cancelled: nothing changes any more.
inline bool ended(Lifecycle s) { return s != Lifecycle::queued && s != Lifecycle::running; }

}  // namespace distlab::server
