// distlab mesh-domain: the child process that meshes on several threads for a process that must
// not risk CGAL's parallel refinement itself (distlab/kelvin/isolated_mesher.hpp); not meant to
// be run by hand.
#include <iostream>

#include "command.hpp"
#include "distlab/kelvin/isolated_mesher.hpp"

namespace {

const distlab::app::RegisterCommand kRegister(
    "mesh-domain", {"internal: mesh one inverted domain on several threads (used by serve and kelvin)",
                    [](const std::vector<std::string>& args, std::istream&, std::ostream& out, std::ostream&) {
                      return distlab::kelvin::mesh_domain_child(args, out);
                    }});

}  // namespace
