#include "model/material_params.hpp"

namespace hyperqn {

static std::shared_ptr<ScalarFunction> make_function(const FunctionSpec& f) {
  if (f.kind == "polynomial") return std::make_shared<PolynomialFunction>(f.coefficients);
  if (f.kind == "spline") return std::make_shared<MonotoneSplineFunction>(f.x, f.y);
  return nullptr;
}

// The deck's material description in the form the material factory takes.
MaterialParams material_params(const MaterialSpec& spec) {
  MaterialParams p;
  p.model = spec.model;
  p.mu = spec.mu;
  p.lambda = spec.lambda;
  p.J0 = spec.J0;
  p.kappa = spec.kappa;
  p.f = make_function(spec.f);
  p.g = make_function(spec.g);
  p.h = make_function(spec.h);
  p.has_fiber = spec.has_fiber;
  p.fiber_direction = Vec3(spec.fiber_direction[0], spec.fiber_direction[1], spec.fiber_direction[2]);
  p.fiber_stiffness = spec.fiber_stiffness;
  return p;
}

}  // namespace hyperqn
