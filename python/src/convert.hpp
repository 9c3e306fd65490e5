#pragma once
// Python objects <-> nlohmann::json, walked object by object (no JSON text in between), so the
// bindings feed the CLI's and the service's own request parsers, and their responses come back as
// dicts whose numeric arrays are numpy arrays.
#include <string>

#include <pybind11/pybind11.h>
#include <nlohmann/json.hpp>

namespace distlab::python {

// None, bool, int, float, str, dict (str keys), list/tuple, numpy arrays and scalars. Another
// type raises TypeError naming the path (e.g. "a.size[1]"); nesting deeper than the JSON
// parser's limit is InvalidInput, as for JSON text.
nlohmann::json to_json(pybind11::handle object, const std::string& path = "");

// Objects become dicts; an array of numbers (null allowed: NaN), of booleans, or a rectangular
// nesting of such arrays becomes a numpy array (int64 when every element is an integer, float64
// otherwise, bool for booleans); anything else a list.
pybind11::object to_python(const nlohmann::json& j);

}  // namespace distlab::python
