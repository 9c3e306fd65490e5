// distlab.cbf: a rollout from the CLI's request, with progress and Ctrl-C.
#include <string>

#include "bindings.hpp"
#include "convert.hpp"
#include "distlab/server/cbf_json.hpp"
#include "interrupt.hpp"

namespace py = pybind11;
using json = nlohmann::json;

namespace distlab::python {
namespace {

// progress(step, t) is called every `every` steps; the encoded record is the CLI's response.
py::object cbf_rollout(const py::object& request, const py::object& progress, int every) {
  const json j = to_json(request);
  server::CbfRequest r = server::parse_cbf_request(j);
  Interruptible interrupt(progress);
  const int stride = every > 0 ? every : 1;
  r.options.cancel = interrupt.flag();
  r.options.progress = [&](int step, const cbf::StepRecord& s) {
    return step % stride != 0 ? interrupt.poll() : interrupt.report(step, s.t);
  };
  json response;
  {
    py::gil_scoped_release release;
    const cbf::RolloutRecord record = cbf::rollout(r.scenario, r.metric, r.options);
    if (!interrupt.cancelled()) response = server::encode_record(record, r.scenario.name);
  }
  if (interrupt.cancelled()) interrupt.raise();
  return to_python(response);
}

}  // namespace

void bind_cbf(py::module_& m) {
  m.def("cbf_rollout", &cbf_rollout, py::arg("request"), py::arg("progress") = py::none(), py::arg("every") = 1);
}

}  // namespace distlab::python
