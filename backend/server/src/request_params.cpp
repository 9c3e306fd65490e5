// Reads of request parameters shared by the routes (request_params.hpp).
#include "distlab/server/request_params.hpp"

#include <cctype>
#include <cmath>
#include <stdexcept>

#include "distlab/geometry/error.hpp"

namespace distlab::server {

bool valid_name(const std::string& s) {
  if (s.empty() || s.size() > 64) return false;
  for (char c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '_' && c != '-') return false;
  return true;
}

void single_query(const Request& req, const std::string& name) {
  if (req.repeated_query.count(name))
    throw InvalidInput(name, "query parameter " + name + " is given more than once");
}

double query_number(const Request& req, const std::string& name) {
  single_query(req, name);
  auto it = req.query.find(name);
  if (it == req.query.end()) throw InvalidInput(name, "query parameter " + name + " is required");
  try {
    std::size_t used = 0;
    const double v = std::stod(it->second, &used);
    if (used != it->second.size() || !std::isfinite(v)) throw std::invalid_argument("");
    return v;
  } catch (const std::exception&) {
    throw InvalidInput(name, "query parameter " + name + " must be a finite number");
  }
}

std::size_t query_index(const Request& req, const std::string& name, std::size_t fallback) {
  auto it = req.query.find(name);
  if (it == req.query.end()) return fallback;
  const std::string& v = it->second;
  if (v.empty() || v.size() > 9 || v.find_first_not_of("0123456789") != std::string::npos)
    throw InvalidInput(name, "query parameter " + name + " must be a whole number below 10^9");
  return static_cast<std::size_t>(std::stoul(v));
}

}  // namespace distlab::server
