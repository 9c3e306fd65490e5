#pragma once
// The one error type for bad input: names the offending field (a JSON-pointer-like path such as
// "a.A[3]" or "params.h") so transports can report it without parsing messages.
#include <stdexcept>
#include <string>

namespace distlab {

class InvalidInput : public std::invalid_argument {
 public:
  InvalidInput(std::string field, const std::string& message)
      : std::invalid_argument(message), field_(std::move(field)) {}
  const std::string& field() const { return field_; }

 private:
  std::string field_;
};

}  // namespace distlab
