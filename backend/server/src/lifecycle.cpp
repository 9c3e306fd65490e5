#include "distlab/server/lifecycle.hpp"

namespace distlab::server {

const char* to_string(Lifecycle s) {
  switch (s) {
    case Lifecycle::queued:
      return "queued";
    case Lifecycle::running:
      return "running";
    case Lifecycle::succeeded:
      return "succeeded";
    case Lifecycle::failed:
      return "failed";
    case Lifecycle::cancelled:
      return "cancelled";
  }
  return "unknown";
}

}  // namespace distlab::server
