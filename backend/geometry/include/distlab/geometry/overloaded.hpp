#pragma once
// std::visit helper: Overloaded{[](const A&) {...}, [](const B&) {...}}.

namespace distlab {

template <class... F>
struct Overloaded : F... {
  using F::operator()...;
};
template <class... F>
Overloaded(F...) -> Overloaded<F...>;

}  // namespace distlab
