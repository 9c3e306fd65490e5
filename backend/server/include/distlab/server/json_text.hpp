#pragma once
// Parsing JSON text from clients (HTTP bodies, WebSocket messages, CLI files) with limits, so one
// request cannot pin the parser: part of the core, shared by every feature's codec.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

#include <nlohmann/json.hpp>

#include "distlab/server/config.hpp"

namespace distlab::server {

// How deep a JSON document nests. A property of the format, not a server limit: the deepest schema
// (GAP) needs 6 levels, so anything past 64 is no request of this API whatever the server; and
// it keeps the recursive walks over a document (dump, copies) shallow, which a server raising it
// would not. The Python bindings hold their documents to it too.
inline constexpr int kMaxJsonDepth = 64;

// Malformed JSON text (a syntax error); `byte` is the 1-based offset nlohmann reports.
class JsonSyntaxError : public std::runtime_error {
 public:
  JsonSyntaxError(const std::string& message, std::size_t byte)
      : std::runtime_error(message), byte_(byte) {}
  std::size_t byte() const { return byte_; }

 private:
  std::size_t byte_;
};

// Parses JSON text with the limits above. Throws JsonSyntaxError for malformed text, and
// InvalidInput for text over max_bytes, nesting deeper than kMaxJsonDepth, a duplicate key, or a
// number that overflows a double (e.g. 1e999; the field names where it is).
nlohmann::json parse_json_text(std::string_view text, std::size_t max_bytes = Limits{}.max_body_bytes);

// A msgpack body (frames.hpp's codec, e.g. a scene item) with the same depth and duplicate-key
// limits; "bin" values become json::binary. Malformed bytes are InvalidInput naming "body". The
// caller bounds the size (the route's body limit).
nlohmann::json parse_msgpack(std::string_view bytes);

// User-supplied names go into messages; keep them short (cut on a UTF-8 boundary).
std::string shorten(const std::string& s, std::size_t max = 64);

}  // namespace distlab::server
