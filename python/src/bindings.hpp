#pragma once
// Registration of each module's bindings into the extension module distlab._core.
#include <pybind11/pybind11.h>

namespace distlab::python {

void bind_gap(pybind11::module_& m);
void bind_kelvin(pybind11::module_& m);
void bind_cbf(pybind11::module_& m);
void bind_robot(pybind11::module_& m);

}  // namespace distlab::python
