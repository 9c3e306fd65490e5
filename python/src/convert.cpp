#include "convert.hpp"

#include <cstdint>
#include <optional>
#include <vector>

#include <pybind11/numpy.h>

#include "distlab/geometry/error.hpp"
#include "distlab/server/gap_json.hpp"
#include "distlab/server/json_fields.hpp"

namespace py = pybind11;
using json = nlohmann::json;

namespace distlab::python {
namespace {

json convert(py::handle o, const std::string& path, int depth) {
  if (depth > server::kMaxJsonDepth)
    throw InvalidInput("", "JSON nested deeper than " + std::to_string(server::kMaxJsonDepth) + " levels");
  if (o.is_none()) return nullptr;
  if (PyBool_Check(o.ptr())) return o.ptr() == Py_True;
  if (PyLong_Check(o.ptr())) {
    // As nlohmann's parser reads integer text: non-negative ones unsigned.
    int overflow = 0;
    const long long v = PyLong_AsLongLongAndOverflow(o.ptr(), &overflow);
    if (overflow == 0) return v >= 0 ? json(static_cast<std::uint64_t>(v)) : json(v);
    const unsigned long long u = PyLong_AsUnsignedLongLong(o.ptr());
    if (PyErr_Occurred()) {
      PyErr_Clear();
      return PyLong_AsDouble(o.ptr());  // as the parser turns a huge integer into a double
    }
    return json(static_cast<std::uint64_t>(u));
  }
  if (PyFloat_Check(o.ptr())) return PyFloat_AS_DOUBLE(o.ptr());
  if (PyUnicode_Check(o.ptr())) return o.cast<std::string>();
  if (PyDict_Check(o.ptr())) {
    json out = json::object();
    for (auto [k, v] : py::reinterpret_borrow<py::dict>(o)) {
      if (!PyUnicode_Check(k.ptr()))
        throw py::type_error((path.empty() ? std::string("the request") : path) +
                             ": keys must be strings, got " + std::string(py::str(py::type::of(k).attr("__name__"))));
      const std::string key = k.cast<std::string>();
      out[key] = convert(v, server::json_key_path(path, key), depth + 1);
    }
    return out;
  }
  if (PyList_Check(o.ptr()) || PyTuple_Check(o.ptr())) {
    json out = json::array();
    std::size_t i = 0;
    for (py::handle e : o) out.push_back(convert(e, server::json_index_path(path, i++), depth + 1));
    return out;
  }
  // numpy: arrays through tolist() (exact Python ints and floats), scalars through item().
  if (py::isinstance<py::array>(o)) return convert(o.attr("tolist")(), path, depth);
  if (py::hasattr(o, "dtype") && py::hasattr(o, "item")) return convert(o.attr("item")(), path, depth);
  throw py::type_error((path.empty() ? std::string("the request") : path) + ": cannot use a " +
                       std::string(py::str(py::type::of(o).attr("__name__"))) +
                       " here (expected None, bool, int, float, str, dict, list or a numpy array)");
}

// The shape of a rectangular numeric array (empty optional: not one); kind: 0 none yet,
// 1 integers, 2 floats (or null), 3 booleans.
bool shape_of(const json& j, std::size_t level, std::vector<std::size_t>& shape, int& kind) {
  if (j.is_array()) {
    if (level == shape.size()) {
      if (level > 0 && kind != 0) return false;  // arrays beside scalars
      shape.push_back(j.size());
    } else if (shape[level] != j.size()) {
      return false;
    }
    for (const json& e : j)
      if (!shape_of(e, level + 1, shape, kind)) return false;
    return true;
  }
  if (level != shape.size()) return j.is_null() && kind != 3 && (kind = 2, true);  // a null row: NaN
  if (j.is_boolean()) {
    if (kind != 0 && kind != 3) return false;
    kind = 3;
    return true;
  }
  if (j.is_number_integer()) {
    if (kind == 3) return false;
    if (kind == 0) kind = 1;
    return true;
  }
  if (j.is_number_float() || j.is_null()) {
    if (kind == 3) return false;
    kind = 2;
    return true;
  }
  return false;
}

template <class T>
void fill(const json& j, std::size_t level, const std::vector<std::size_t>& shape, T*& out) {
  if (j.is_array()) {
    for (const json& e : j) fill(e, level + 1, shape, out);
    return;
  }
  std::size_t count = 1;  // a null standing for a whole row
  for (std::size_t l = level; l < shape.size(); ++l) count *= shape[l];
  for (std::size_t i = 0; i < count; ++i)
    *out++ = j.is_null() ? static_cast<T>(NAN) : j.get<T>();
}

template <class T>
py::object make_array(const json& j, const std::vector<std::size_t>& shape) {
  std::vector<py::ssize_t> dims(shape.begin(), shape.end());
  py::array_t<T> a(dims);
  T* p = a.mutable_data();
  fill(j, 0, shape, p);
  return a;
}

}  // namespace

json to_json(py::handle object, const std::string& path) { return convert(object, path, 0); }

py::object to_python(const json& j) {
  switch (j.type()) {
    case json::value_t::null:
      return py::none();
    case json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case json::value_t::number_integer:
      return py::int_(j.get<std::int64_t>());
    case json::value_t::number_unsigned:
      return py::int_(j.get<std::uint64_t>());
    case json::value_t::number_float:
      return py::float_(j.get<double>());
    case json::value_t::string:
      return py::str(j.get<std::string>());
    case json::value_t::object: {
      py::dict d;
      for (const auto& [k, v] : j.items()) d[py::str(k)] = to_python(v);
      return d;
    }
    case json::value_t::array: {
      std::vector<std::size_t> shape;
      int kind = 0;
      if (!j.empty() && shape_of(j, 0, shape, kind) && kind != 0) {
        if (kind == 1) return make_array<std::int64_t>(j, shape);
        if (kind == 2) return make_array<double>(j, shape);
        return make_array<bool>(j, shape);
      }
      py::list l;
      for (const json& e : j) l.append(to_python(e));
      return l;
    }
    default:
      return py::none();  // binary and discarded values do not occur in responses
  }
}

}  // namespace distlab::python
