#pragma once
// Reads of request parameters shared by the routes: names of assets and scenarios, and query
// parameters (each refused with its name when repeated or malformed).
#include <cstddef>
#include <string>

#include "distlab/server/http.hpp"

namespace distlab::server {

// 1 to 64 letters, digits, '_' and '-' (a file stem that cannot leave its folder).
bool valid_name(const std::string& s);

// A query parameter given more than once is refused, not silently reduced to its first value.
void single_query(const Request& req, const std::string& name);

// A required query parameter that is a finite number.
double query_number(const Request& req, const std::string& name);

// An optional query parameter that is a whole number below 10^9 (fallback when absent).
std::size_t query_index(const Request& req, const std::string& name, std::size_t fallback);

}  // namespace distlab::server
