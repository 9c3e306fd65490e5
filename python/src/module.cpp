// distlab._core: the C++ half of the distlab package (the pure-Python modules wrap it).
#include "bindings.hpp"
#include "distlab/cbf/fields.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/server/gap_json.hpp"

namespace py = pybind11;

PYBIND11_MODULE(_core, m) {
  m.doc() = "distlab's numerical cores (GAP, Kelvin, CBF, robots) through the CLI's own request codecs";
  // InvalidInput(field, message) becomes distlab.errors.InvalidInput (a ValueError, or also a
  // TypeError when the value has the wrong JSON type), with .field.
  // By value: pybind11's ExceptionTranslator is void (*)(std::exception_ptr).
  py::register_exception_translator([](std::exception_ptr p) {  // NOLINT(performance-unnecessary-value-param)
    try {
      if (p) std::rethrow_exception(p);
    } catch (const distlab::InvalidInput& e) {
      const py::object error = py::module_::import("distlab.errors").attr("invalid_input")(e.field(), e.what());
      PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(error.ptr())), error.ptr());
    } catch (const distlab::server::JsonSyntaxError& e) {
      PyErr_SetString(PyExc_ValueError, e.what());
    } catch (const distlab::cbf::FieldUndefined& e) {
      PyErr_SetString(py::module_::import("distlab.errors").attr("FieldUndefined").ptr(), e.what());
    }
  });
  distlab::python::bind_gap(m);
  distlab::python::bind_kelvin(m);
  distlab::python::bind_cbf(m);
  distlab::python::bind_robot(m);
}
