#pragma once
// A check of a URDF text before any XML parser sees it (urdf.cpp runs it first).
#include <string>

namespace distlab::robot {

// Refuses, with InvalidInput(field) naming the line, a text whose elements nest deeper than 64 or
// that has an element with more than 64 attributes: TinyXML 1 (urdfdom's parser, and the one
// from_urdf reads origins with) recurses once per nesting level and looks up every attribute among
// the element's earlier ones, so 40 000 levels cost it 13 s per parse and 100 000 overflow an 8 MB
// stack, and 100 000 attributes of one element cost it 28 s. A URDF nests about 6 deep.
void check_urdf_text(const std::string& text, const std::string& field);

}  // namespace distlab::robot
