// STL import (stl.hpp): binary by its size formula, ASCII by its keywords, never by the first
// bytes alone (binary headers may start with "solid"; ASCII files put a tab or a name after it).
#include "stl.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <optional>
#include <string_view>

#include "distlab/geometry/error.hpp"
#include "distlab/mesh/surface.hpp"
#include "number_word.hpp"

namespace distlab::mesh {

namespace {

constexpr std::string_view kSpace = " \t\r\n\f\v";

// An STL has no vertex list: corners with the same position are one vertex, numbered in order of
// first appearance (facet by facet, three corners each). −0 and +0 are one position.
template <class T>
class Welder {
 public:
  std::size_t operator()(const std::array<T, 3>& p, std::vector<detail::Point>& points) {
    auto [it, inserted] = first_.emplace(std::array<T, 3>{p[0] + T(0), p[1] + T(0), p[2] + T(0)}, points.size());
    if (inserted) points.emplace_back(p[0], p[1], p[2]);
    return it->second;
  }

 private:
  std::map<std::array<T, 3>, std::size_t> first_;
};

// The words of a text and the line each is on (from 1).
class Words {
 public:
  explicit Words(std::string_view text) : text_(text) {}
  // The next word, or "" at the end of the text.
  std::string_view next() {
    for (; at_ < text_.size() && kSpace.find(text_[at_]) != std::string_view::npos; ++at_) line_ += text_[at_] == '\n' ? 1 : 0;
    const std::size_t start = at_;
    at_ = std::min(text_.find_first_of(kSpace, at_), text_.size());
    return text_.substr(start, at_ - start);
  }
  // The rest of the current line (a solid's name, which may hold spaces).
  void skip_line() { at_ = std::min(text_.find('\n', at_), text_.size()); }
  std::size_t line() const { return line_; }

 private:
  std::string_view text_;
  std::size_t at_ = 0, line_ = 1;
};

// Keywords compared without case: some exporters write them in capitals.
bool is(std::string_view word, std::string_view keyword) {
  return word.size() == keyword.size() && std::equal(word.begin(), word.end(), keyword.begin(), [](char a, char b) {
           return std::tolower(static_cast<unsigned char>(a)) == b;
         });
}

// Text as an ASCII STL is: no control byte other than whitespace.
bool is_text(std::string_view bytes) {
  return std::none_of(bytes.begin(), bytes.end(), [](char c) {
    return static_cast<unsigned char>(c) < 0x20 && kSpace.find(c) == std::string_view::npos;
  });
}

// ASCII STL: "solid [name]" then facets ("facet normal x y z", "outer loop", three "vertex x y
// z", "endloop", "endfacet") and "endsolid [name]", possibly several solids.
void read_ascii(std::string_view text, std::vector<detail::Point>& points, std::vector<std::vector<std::size_t>>& soup,
                const std::string& field) {
  Words words(text);
  std::string_view word;
  const auto refuse = [&](const std::string& expected) {
    throw InvalidInput(field, "ASCII STL, line " + std::to_string(words.line()) + ": expected " + expected + ", found " +
                                  (word.empty() ? std::string("the end of the file") : "'" + std::string(word.substr(0, 32)) + "'"));
  };
  const auto expect = [&](std::string_view keyword) {
    word = words.next();
    if (!is(word, keyword)) refuse("\"" + std::string(keyword) + "\"");
  };
  const auto number = [&](const char* what) {
    word = words.next();
    const std::optional<double> x = detail::number_word(word);
    if (!x) refuse(what);
    return *x;
  };
  Welder<double> weld;
  word = words.next();  // "solid", as read_stl found it
  words.skip_line();
  for (std::size_t facet = 0;;) {
    word = words.next();
    if (is(word, "endsolid")) {
      words.skip_line();
      word = words.next();
      if (word.empty()) break;
      if (!is(word, "solid")) refuse("\"solid\" or the end of the file after \"endsolid\"");
      words.skip_line();
      continue;
    }
    if (!is(word, "facet")) refuse(word.empty() ? "\"endsolid\" (the file is truncated)" : "\"facet\" or \"endsolid\"");
    expect("normal");
    for (int k = 0; k < 3; ++k) number("a normal's coordinate");  // unused: the corners' order decides
    expect("outer");
    expect("loop");
    std::vector<std::size_t> corners;
    for (word = words.next(); is(word, "vertex"); word = words.next()) {
      std::array<double, 3> p{};
      for (double& x : p) x = number("a vertex coordinate");
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw InvalidInput(field, "ASCII STL, line " + std::to_string(words.line()) + ": a vertex has a non-finite coordinate (NaN or infinity)");
      corners.push_back(weld(p, points));
    }
    if (!is(word, "endloop")) refuse("\"vertex\" or \"endloop\"");
    if (corners.size() != 3)
      throw InvalidInput(field, "ASCII STL, line " + std::to_string(words.line()) + ": facet " + std::to_string(facet) + " has " +
                                    std::to_string(corners.size()) + " vertices; an STL facet is a triangle");
    expect("endfacet");
    soup.push_back(std::move(corners));
    ++facet;
  }
  if (soup.empty()) throw InvalidInput(field, "the ASCII STL has no facets");
}

// Binary STL: an 80-byte header, a uint32 count n, then n records of 50 bytes (normal, three
// corners, an attribute word).
void read_binary(std::string_view bytes, std::uint32_t n, std::vector<detail::Point>& points, std::vector<std::vector<std::size_t>>& soup,
                 const std::string& field) {
  if (n == 0) throw InvalidInput(field, "the binary STL declares no triangles (its count is 0)");
  Welder<float> weld;
  soup.reserve(n);
  for (std::uint32_t f = 0; f < n; ++f) {
    std::vector<std::size_t> corners;
    for (int c = 0; c < 3; ++c) {
      std::array<float, 3> p{};
      std::memcpy(p.data(), bytes.data() + 84 + 50 * static_cast<std::size_t>(f) + 12 * (1 + c), 12);
      if (!std::isfinite(p[0]) || !std::isfinite(p[1]) || !std::isfinite(p[2]))
        throw InvalidInput(field, "triangle " + std::to_string(f) + " has a non-finite coordinate (NaN or infinity)");
      corners.push_back(weld(p, points));
    }
    soup.push_back(std::move(corners));
  }
}

// Binary when the size is 84 + 50·n for the count n in bytes 80-83 (an ASCII file's bytes there
// would make n above 5·10⁸, a file of 27 GB). Otherwise ASCII when the first word is "solid" and
// what follows its line is "facet" or "endsolid", or the file is text (the parse then names the
// line that is wrong). Anything else is a binary file of the wrong size, or no STL.
std::optional<std::uint32_t> classify(std::string_view bytes, const std::string& field) {
  std::uint32_t n = 0;
  if (bytes.size() >= 84) {
    std::memcpy(&n, bytes.data() + 80, 4);  // little-endian, as the format and every target are
    if (bytes.size() == 84 + 50 * static_cast<std::uint64_t>(n)) return n;
  }
  Words words(bytes);
  const bool solid = is(words.next(), "solid");
  words.skip_line();
  const std::string_view then = words.next();
  const bool text = is_text(bytes);
  if (solid && (text || is(then, "facet") || is(then, "endsolid"))) return std::nullopt;
  std::string why = "not a valid STL file: ";
  if (solid)
    why += "it starts with \"solid\" like an ASCII STL but holds binary bytes, so it is read as binary; ";
  else if (text)
    why += "it is text, but an ASCII STL starts with \"solid\"; as binary: ";
  why += "a binary STL is exactly 84 + 50·n bytes (n triangles)";
  if (bytes.size() < 84)
    why += ", but the file has only " + std::to_string(bytes.size()) + " bytes";
  else
    why += "; its header says n = " + std::to_string(n) + ", i.e. " + std::to_string(84 + 50 * static_cast<std::uint64_t>(n)) +
           " bytes, but the file has " + std::to_string(bytes.size()) + " bytes (truncated, or not an STL)";
  throw InvalidInput(field, why);
}

}  // namespace

std::optional<std::uint32_t> binary_stl_triangles(std::string_view bytes, const std::string& field) { return classify(bytes, field); }

void detail::read_stl(const std::string& bytes, std::vector<Point>& points, std::vector<std::vector<std::size_t>>& soup,
                      const std::string& field) {
  if (const auto n = classify(bytes, field)) read_binary(bytes, *n, points, soup, field);
  else read_ascii(bytes, points, soup, field);
}

}  // namespace distlab::mesh
