#pragma once
// Kelvin preparation reports progress and is cancelled through the project's one token.
#include "distlab/geometry/progress.hpp"

namespace distlab::kelvin {

using distlab::Cancelled;
using distlab::Progress;

}  // namespace distlab::kelvin
