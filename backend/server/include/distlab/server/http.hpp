#pragma once
// Transport-neutral HTTP request/response values and the error type of the API: the Beast layer
// converts to and from these, so the router and the endpoints can be tested without sockets.
#include <exception>
#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/geometry/error.hpp"

namespace distlab::server {

struct Request {
  std::string method;                          // upper case: GET, POST, PUT, DELETE, HEAD, ...
  std::string target;                          // as received: path + optional ?query
  std::string path;                            // target without the query string, not percent-decoded
  std::map<std::string, std::string> query;    // decoded query parameters (the first of repeats)
  std::set<std::string> repeated_query;        // query parameters given more than once
  std::map<std::string, std::string> headers;  // lower-case names
  std::string body;
  std::map<std::string, std::string> params;  // path parameters filled in by the router
  std::string remote_address;                 // the client's IP address ("" when not on a socket)

  std::string header(const std::string& lower_name) const;
  // The client session id: header X-Distlab-Session, else cookie distlab_session, else the query
  // parameter "session" (browsers cannot set headers on WebSocket upgrades). Empty if none.
  std::string session_id() const;
};

struct Response {
  int status = 200;
  std::string content_type = "application/json";
  std::string body;
  std::vector<std::pair<std::string, std::string>> headers;
};

// An API failure with its status: becomes {"error": {"code", "message", "field"}}.
// Input past a limit of the table (config.hpp), thrown by a feature's codec, the one place that
// checks it: HTTP answers status and code (413 too_many_pairs, 422 over_budget, ...); the CLI
// and Python, which know only invalid input, see the InvalidInput it is.
class LimitExceeded : public InvalidInput {
 public:
  LimitExceeded(int status, std::string code, const std::string& field, const std::string& message)
      : InvalidInput(field, message), status_(status), code_(std::move(code)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }

 private:
  int status_;
  std::string code_;
};

class ApiError : public std::runtime_error {
 public:
  ApiError(int status, std::string code, const std::string& message, std::string field = "")
      : std::runtime_error(message), status_(status), code_(std::move(code)), field_(std::move(field)) {}
  int status() const { return status_; }
  const std::string& code() const { return code_; }
  const std::string& field() const { return field_; }

 private:
  int status_;
  std::string code_, field_;
};

// An error answer: its HTTP status and {"code", "message", "field"} (body()).
struct ErrorAnswer {
  int status = 500;
  std::string code, message, field;
  nlohmann::json body() const;
};

// The one mapping of an exception (a request's, a job's, a WebSocket message's, a frame's) to the
// error answer: ApiError and LimitExceeded as they say, InvalidInput 400 invalid_input,
// JsonSyntaxError 400 malformed_json, bad_alloc 503 out_of_memory. Anything else is the server's
// fault: 500 with `internal_code` and `internal_message`; its own text may name server files, so
// it goes only to the log, as "distlab serve: <log_context>: <text>" (no line when log_context is
// null: the caller rethrows to a mapping that logs it).
ErrorAnswer error_answer(const std::exception_ptr& error, const std::string& internal_code = "internal_error",
                         const std::string& internal_message = "internal error", const char* log_context = "internal error");

Response json_response(int status, const nlohmann::json& body);
// 204 No Content: no body and no Content-Type (the answer to a DELETE).
Response no_content_response();
Response error_response(int status, const std::string& code, const std::string& message,
                        const std::string& field = "");

// Splits "path?a=1&b=2" and percent-decodes the query ('+' is a space there). A repeated key keeps
// its first value; its name goes to *repeated when given.
void split_target(const std::string& target, std::string& path, std::map<std::string, std::string>& query,
                  std::set<std::string>* repeated = nullptr);
// Percent-decoding; returns false on a malformed escape or an encoded NUL.
bool percent_decode(const std::string& in, std::string& out, bool plus_is_space = false);

// Parses a JSON request body with the GAP codec's limits (depth, duplicates, overflow); maps
// syntax errors to 400 malformed_json and an empty body to 400.
nlohmann::json parse_body(const Request& request);

// Random identifier: 128 bits from the OS generator, as 32 hex digits.
std::string random_id();

}  // namespace distlab::server
