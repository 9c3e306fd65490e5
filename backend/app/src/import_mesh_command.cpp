// distlab import-mesh: the child process that parses one untrusted mesh file for the server
// (distlab/mesh/isolated_import.hpp); not meant to be run by hand.
#include <iostream>

#include "command.hpp"
#include "distlab/mesh/isolated_import.hpp"

namespace {

const distlab::app::RegisterCommand kRegister(
    "import-mesh", {"internal: parse one mesh file with resource limits (used by serve)",
                    [](const std::vector<std::string>& args, std::istream&, std::ostream& out, std::ostream&) {
                      return distlab::mesh::import_mesh_child(args, out);
                    }});

}  // namespace
