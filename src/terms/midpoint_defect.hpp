// The implicit midpoint's energy test (EnergyTerm::add_midpoint_defect) for a term known only by its
// energy: E(end) - E(start) - dE/dx(z) . (end - start), the derivative along the step a central
// difference E(z + e d) - E(z - e d) over 2e, d = end - start over every vertex (fixed ones at their
// own times), e = 1e-3 (its truncation error e^2 of the defect's own third-order size; its round-off
// 1e-13 of E). For cloth membranes and hinges; the springs have theirs in closed form (SpringSet).
#pragma once
#include <cmath>
#include <vector>

#include "terms/energy_term.hpp"

namespace hyperqn {

inline void midpoint_defect_by_energy(const EnergyTerm& term, const std::vector<double>& start,
                                      const std::vector<double>& z, const std::vector<double>& end, double* defect,
                                      double* scale) {
  constexpr double e = 1e-3;
  double Es = 0, Ee = 0, Ep = 0, Em = 0;
  term.add_energy(nullptr, start, &Es, nullptr);
  term.add_energy(nullptr, end, &Ee, nullptr);
  std::vector<double> p(z.size());
  for (size_t i = 0; i < p.size(); ++i) p[i] = z[i] + e * (end[i] - start[i]);
  term.add_energy(nullptr, p, &Ep, nullptr);
  for (size_t i = 0; i < p.size(); ++i) p[i] = z[i] - e * (end[i] - start[i]);
  term.add_energy(nullptr, p, &Em, nullptr);
  const double W = (Ep - Em) / (2 * e);
  *defect += Ee - Es - W;
  *scale += std::fabs(Es) + std::fabs(Ee) + std::fabs(W);
}

}  // namespace hyperqn
