// Request/response helpers, percent-decoding, ids.
#include "distlab/server/http.hpp"

#include <sys/random.h>

#include <cstdio>
#include <random>

#include "distlab/geometry/error.hpp"
#include "distlab/server/json_text.hpp"

namespace distlab::server {

std::string Request::header(const std::string& lower_name) const {
  auto it = headers.find(lower_name);
  return it == headers.end() ? std::string() : it->second;
}

std::string Request::session_id() const {
  std::string id = header("x-distlab-session");
  if (!id.empty()) return id;
  const std::string cookies = header("cookie");
  std::size_t pos = 0;
  while (pos < cookies.size()) {
    std::size_t end = cookies.find(';', pos);
    if (end == std::string::npos) end = cookies.size();
    std::string item = cookies.substr(pos, end - pos);
    const std::size_t first = item.find_first_not_of(' ');
    if (first != std::string::npos) item = item.substr(first);
    if (item.rfind("distlab_session=", 0) == 0) return item.substr(16);
    pos = end + 1;
  }
  auto it = query.find("session");
  return it == query.end() ? std::string() : it->second;
}

Response json_response(int status, const nlohmann::json& body) {
  Response r;
  r.status = status;
  r.body = body.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  return r;
}

Response no_content_response() {
  Response r;
  r.status = 204;
  r.content_type.clear();
  return r;
}

nlohmann::json ErrorAnswer::body() const { return {{"code", code}, {"message", message}, {"field", field}}; }

ErrorAnswer error_answer(const std::exception_ptr& error, const std::string& internal_code,
                         const std::string& internal_message, const char* log_context) {
  try {
    std::rethrow_exception(error);
  } catch (const ApiError& e) {
    return {e.status(), e.code(), e.what(), e.field()};
  } catch (const LimitExceeded& e) {
    return {e.status(), e.code(), e.what(), e.field()};
  } catch (const InvalidInput& e) {
    return {400, "invalid_input", e.what(), e.field()};
  } catch (const JsonSyntaxError& e) {
    return {400, "malformed_json", "malformed JSON at byte " + std::to_string(e.byte()), ""};
  } catch (const std::bad_alloc&) {
    return {503, "out_of_memory", "the server ran out of memory for this request", ""};
  } catch (const std::exception& e) {
    if (log_context != nullptr) std::fprintf(stderr, "distlab serve: %s: %s\n", log_context, e.what());
    return {500, internal_code, internal_message, ""};
  }
}

Response error_response(int status, const std::string& code, const std::string& message,
                        const std::string& field) {
  return json_response(status, {{"error", {{"code", code}, {"message", message}, {"field", field}}}});
}

bool percent_decode(const std::string& in, std::string& out, bool plus_is_space) {
  out.clear();
  out.reserve(in.size());
  auto hex = [](char c) -> int {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
  };
  for (std::size_t i = 0; i < in.size(); ++i) {
    const char c = in[i];
    if (c == '%') {
      if (i + 2 >= in.size()) return false;
      const int hi = hex(in[i + 1]), lo = hex(in[i + 2]);
      if (hi < 0 || lo < 0) return false;
      const char d = static_cast<char>(hi * 16 + lo);
      if (d == '\0') return false;
      out.push_back(d);
      i += 2;
    } else if (c == '+' && plus_is_space) {
      out.push_back(' ');
    } else {
      out.push_back(c);
    }
  }
  return true;
}

void split_target(const std::string& target, std::string& path, std::map<std::string, std::string>& query,
                  std::set<std::string>* repeated) {
  const std::size_t q = target.find('?');
  path = target.substr(0, q);
  query.clear();
  if (repeated) repeated->clear();
  if (q == std::string::npos) return;
  const std::string qs = target.substr(q + 1);
  std::size_t pos = 0;
  while (pos <= qs.size()) {
    std::size_t end = qs.find('&', pos);
    if (end == std::string::npos) end = qs.size();
    const std::string item = qs.substr(pos, end - pos);
    if (!item.empty()) {
      const std::size_t eq = item.find('=');
      std::string key, value;
      if (percent_decode(item.substr(0, eq), key, true) &&
          (eq == std::string::npos || percent_decode(item.substr(eq + 1), value, true)))
        if (!query.emplace(key, value).second && repeated) repeated->insert(key);
    }
    pos = end + 1;
  }
}

nlohmann::json parse_body(const Request& request) {
  if (request.body.empty()) throw ApiError(400, "empty_body", "the request needs a JSON body");
  try {
    // The transport already held the body to its route's limit (Service::body_limit).
    return parse_json_text(request.body, request.body.size());
  } catch (const JsonSyntaxError& e) {
    throw ApiError(400, "malformed_json", "malformed JSON at byte " + std::to_string(e.byte()));
  }
}

std::string random_id() {
  unsigned char bytes[16];
  std::size_t got = 0;
  while (got < sizeof bytes) {
    const ssize_t n = getrandom(bytes + got, sizeof bytes - got, 0);
    if (n <= 0) break;
    got += static_cast<std::size_t>(n);
  }
  if (got < sizeof bytes) {
    std::random_device rd;
    for (auto& b : bytes) b = static_cast<unsigned char>(rd());
  }
  char out[33];
  for (int i = 0; i < 16; ++i) std::snprintf(out + 2 * i, 3, "%02x", bytes[i]);
  return std::string(out, 32);
}

}  // namespace distlab::server
