// distlab.cbf: a rollout or a parameter sweep from the CLI's request, with progress and Ctrl-C.
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
  r.options.progress.cancel = interrupt.flag();  // Ctrl-C or the callback's exception: Cancelled
  r.options.on_step = [&](int step, const cbf::StepRecord& s) {
    if (step % stride != 0) interrupt.poll();
    else interrupt.report(step, s.t);
  };
  json response;
  {
    py::gil_scoped_release release;
    try {
      response = server::encode_record(cbf::rollout(r.scenario, r.metric, r.options), r.scenario.name);
    } catch (const Cancelled&) {  // raised below as what cancelled it
    }
  }
  if (interrupt.cancelled()) interrupt.raise();
  return to_python(response);
}

// A sweep ("sweep" in the request) on all cores: `distlab cbf`'s response; progress(stage,
// fraction) as the service's sweep job reports it.
py::object cbf_sweep(const py::object& request, const py::object& progress) {
  const json j = to_json(request);
  Interruptible interrupt(progress);
  Progress p;
  p.cancel = interrupt.flag();
  p.report = [&](const std::string& stage, double f) { interrupt.report(stage, f); };
  json response;
  interrupt.run([&] { response = server::run_cbf_sweep(j, p); });
  return to_python(response);
}

}  // namespace

void bind_cbf(py::module_& m) {
  m.def("cbf_rollout", &cbf_rollout, py::arg("request"), py::arg("progress") = py::none(), py::arg("every") = 1);
  m.def("cbf_sweep", &cbf_sweep, py::arg("request"), py::arg("progress") = py::none());
}

}  // namespace distlab::python
