#pragma once
// A number written as one word of a text mesh file (ASCII STL, OBJ), read whole as from_chars
// reads it (no locale), with the leading '+' the formats' C readers also take.
#include <charconv>
#include <optional>
#include <string_view>
#include <system_error>

namespace distlab::mesh::detail {

inline std::optional<double> number_word(std::string_view word) {
  const std::string_view digits = word.substr(word.rfind('+', 0) == 0 ? 1 : 0);  // from_chars takes no '+'
  double x = 0;
  const auto [end, error] = std::from_chars(digits.data(), digits.data() + digits.size(), x);
  if (digits.empty() || error != std::errc() || end != digits.data() + digits.size()) return std::nullopt;
  return x;
}

}  // namespace distlab::mesh::detail
