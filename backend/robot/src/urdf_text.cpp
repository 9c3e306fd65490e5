// The pre-scan of a URDF text (urdf_text.hpp): every caller of Robot::from_urdf (the server's
// URDF texts, Python's files) is protected from nesting and attribute counts TinyXML cannot take.
#include "urdf_text.hpp"

#include <algorithm>
#include <cctype>
#include <cstddef>

#include "distlab/geometry/error.hpp"

namespace distlab::robot {
namespace {

constexpr int kMaxUrdfDepth = 64;
constexpr int kMaxUrdfAttributes = 64;

bool name_char(char c) {
  return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.' || c == ':';
}

}  // namespace

// The scan reads a strict subset of XML in which it finds the same elements TinyXML does:
// elements with quoted attribute values, text, comments, and processing instructions without a
// '>' inside; anything else (CDATA, DOCTYPE, unquoted values) is refused, so no construct can
// hide nesting from it.
void check_urdf_text(const std::string& text, const std::string& field) {
  const std::size_t n = text.size();
  int depth = 0, line = 1;
  const auto at = [&](const std::string& what) { throw InvalidInput(field, "robot URDF: " + what + " (line " + std::to_string(line) + ")"); };
  const auto advance_to = [&](std::size_t from, std::size_t to) {
    line += static_cast<int>(std::count(text.begin() + static_cast<std::ptrdiff_t>(from), text.begin() + static_cast<std::ptrdiff_t>(std::min(to, n)), '\n'));
  };
  for (std::size_t i = 0; i < n;) {
    if (text[i] != '<') {
      if (text[i] == '\n') ++line;
      ++i;
      continue;
    }
    if (text.compare(i, 4, "<!--") == 0) {
      const std::size_t end = text.find("-->", i + 4);
      if (end == std::string::npos) at("a comment is not closed");
      advance_to(i, end);
      i = end + 3;
    } else if (text.compare(i, 2, "<?") == 0) {
      const std::size_t end = text.find('>', i);
      if (end == std::string::npos || text[end - 1] != '?') at("a processing instruction must end with \"?>\" and hold no '>'");
      advance_to(i, end);
      i = end + 1;
    } else if (text.compare(i, 2, "<!") == 0) {
      at("only comments may start with \"<!\" (no DOCTYPE, no CDATA)");
    } else if (text.compare(i, 2, "</") == 0) {
      const std::size_t end = text.find('>', i);
      if (end == std::string::npos) at("an end tag is not closed");
      --depth;
      advance_to(i, end);
      i = end + 1;
    } else {
      if (i + 1 >= n || !(std::isalpha(static_cast<unsigned char>(text[i + 1])) || text[i + 1] == '_'))
        at("'<' must start an element, an end tag, a comment or \"<?\"");
      if (++depth > kMaxUrdfDepth) at("elements nest deeper than " + std::to_string(kMaxUrdfDepth));
      int attributes = 0;
      bool closed = false;
      for (i += 2; i < n && !closed;) {
        const char c = text[i];
        if (c == '>') {
          closed = true;
        } else if (c == '/' && i + 1 < n && text[i + 1] == '>') {
          --depth;
          closed = true;
          ++i;
        } else if (c == '=') {
          if (++attributes > kMaxUrdfAttributes) at("an element has more than " + std::to_string(kMaxUrdfAttributes) + " attributes");
          std::size_t v = i + 1;
          while (v < n && std::isspace(static_cast<unsigned char>(text[v]))) ++v;
          if (v >= n || (text[v] != '"' && text[v] != '\'')) at("attribute values must be quoted");
          const std::size_t end = text.find(text[v], v + 1);
          if (end == std::string::npos) at("an attribute value is not closed");
          advance_to(i, end);
          i = end;
        } else if (c == '\n') {
          ++line;
        } else if (!name_char(c) && !std::isspace(static_cast<unsigned char>(c))) {
          at(std::string("unexpected '") + c + "' in a tag");
        }
        ++i;
      }
      if (!closed) at("a tag is not closed");
    }
  }
}

}  // namespace distlab::robot
