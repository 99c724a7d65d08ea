// A material's fracture criterion (deck material.fracture, docs/topology.md#fracture): which value
// of an interior face between two tets breaks it, and at what threshold, spread per face by a
// seeded random factor. The faces it selects separate as scripted cuts' faces do. No PETSc.
#pragma once
#include <cstdint>
#include <string>
#include <vector>

#include "params/deck_keys.hpp"

namespace hyperqn {

// normal_stress: n . sigma . n on the face, sigma the mean of its two tets' Cauchy stresses and n
// the face's unit normal at the current positions (Rankine's maximum principal stress, taken on the
// faces the mesh has). energy_density: the mean of its two tets' strain energy per unit rest volume.
enum class FractureCriterion { normal_stress, energy_density };
inline const std::vector<std::string> kFractureCriterionNames = {"normal_stress", "energy_density"};  // the enum's order

struct FractureSpec {
  bool given = false;  // the material has a fracture: block
  FractureCriterion criterion = FractureCriterion::normal_stress;
  double threshold = 0;  // the criterion's value at which a face breaks (Pa, or J/m^3)
  double spread = 0;     // each face's threshold is threshold (1 + spread u), u uniform in [-1, 1)
  int seed = 0;          // u's seed: with the face's two tet numbers it gives u
  int resolve = 0;       // after a step with breaks: how many times it may be solved again (the scene: the largest)
  int line = 0;          // the deck line of the block
};

// The deck's material.fracture keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<FractureSpec>>& fracture_keys() {
  using F = FractureSpec;
  static const std::vector<DeckKey<F>> keys = {
      needed(enum_key<F>("criterion", &F::criterion, kFractureCriterionNames,
                         "the value of an interior face: `normal_stress`, n·σ̄·n with σ̄ the mean Cauchy stress of its "
                         "two tets and n its unit normal now; `energy_density`, the mean of their strain energies per "
                         "unit rest volume")),
      needed(DeckKey<F>{"threshold", &F::threshold, "a face breaks once its value exceeds this (its own threshold, with "
                        "`spread`)", above(0, "Pa for normal_stress, J/m^3 for energy_density")}),
      {"spread", &F::spread,
       "each face's threshold is threshold·(1 + spread·u), u uniform in [−1, 1) from `seed` and the face's two tet "
       "numbers (the same at any rank count)", {0, 1, false, true, "0: every face alike"}},
      {"seed", &F::seed, "the seed of the faces' u", at_least(0)},
      {"resolve", &F::resolve,
       "how many times a step whose converged state breaks faces is solved again, from its start with the faces "
       "broken, until no more break (0: they break at the next step's start; the scene takes its materials' largest)",
       at_least(0)},
  };
  return keys;
}

// The face's u in [-1, 1): a hash of (seed, a, b), a < b its two global tet numbers.
inline double fracture_face_u(int seed, int64_t a, int64_t b) {
  auto mix = [](uint64_t z) {  // splitmix64's finalizer
    z += 0x9e3779b97f4a7c15ULL;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
    return z ^ (z >> 31);
  };
  const uint64_t h = mix(mix(mix(uint64_t(seed)) ^ uint64_t(a)) ^ uint64_t(b));
  return 2.0 * double(h >> 11) * 0x1.0p-53 - 1.0;
}

// The threshold of the face between tets a < b.
inline double fracture_face_threshold(const FractureSpec& f, int64_t a, int64_t b) {
  return f.spread == 0 ? f.threshold : f.threshold * (1 + f.spread * fracture_face_u(f.seed, a, b));
}

}  // namespace hyperqn
