#pragma once
// The features `distlab serve` offers, added to a core Service (modules.cpp: one line each).
#include "distlab/server/service.hpp"

namespace distlab::server {

void add_standard_modules(Service& service);

}  // namespace distlab::server
