// Every deck section declared with io/deck_keys.hpp, in the deck's order: what `hyperqn
// --help-deck` prints, `hyperqn registry` exports and scripts/deck_tables.py turns into
// docs/decks.md's tables. The other sections (bodies, material, gravity, petsc) are read by their own functions in app/deck.cpp and documented by hand.
#include "app/deck.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {

const std::vector<DeckKey<StudySpec>>& study_keys() {
  using S = StudySpec;
  static const std::vector<DeckKey<S>> keys = {
      // (the range depends on time.frames: read_study checks it)
      {"frames", &S::frames, "frames at which every solver starts from the same state, each in [1, `time.frames`]"},
      {"solvers", &S::solvers, "the solvers compared", {}, solver_names(), "",
       "every solver (`hyperqn registry`)"},
      {"iterations", &S::iterations, "iteration cap per solver and frame in the per-frame comparison", between(1, 1e6)},
      {"time_limit", &S::time_limit, "per solver and frame", above(0), {}, "s"},
      {"reference_rtol", &S::reference_rtol,
       "the reference Newton (exact Hessian) stops at ‖∇g‖ ≤ reference_rtol·‖∇g(x₀)‖", {0, 1, true, true}},
      {"trajectory", &S::trajectory, "also run every solver over all frames against the converged trajectory"},
      custom_key<S>("trajectory_iterations", "map solver → integer ≥ 1",
                    "per-frame budget of each solver in the trajectory mode", "`solver.iterations`"),
      custom_key<S>("integrators", "list of `time.integrator` names, each once",
                    "the integrator axis: the whole study once per integrator (its own factor and converged "
                    "reference), into `OUTDIR/<integrator>/`; the report script takes `OUTDIR` for all of them. Not "
                    "`implicit-midpoint` with `colliders`",
                    "(none: `time.integrator` alone)"),
  };
  return keys;
}

std::vector<KeyInfo> declared_deck_keys() {
  std::vector<KeyInfo> all;
  for (const std::vector<KeyInfo>& section :
       {key_infos("mesh", mesh_keys()), key_infos("strand_material", strand_material_keys()), key_infos("cloth", cloth_keys()),
        key_infos("fixed", fixed_keys()), key_infos("motion", motion_keys()),
        key_infos("attachments", attachment_keys()), key_infos("colliders", collider_keys()),
        key_infos("contact", contact_keys()),
        key_infos("regions", region_keys()), key_infos("initial", initial_keys()), key_infos("time", time_keys()), key_infos("solver", solver_keys()), key_infos("output", output_keys()),
        key_infos("checkpoint", checkpoint_keys()), key_infos("study", study_keys())})
    all.insert(all.end(), section.begin(), section.end());
  return all;
}

}  // namespace hyperqn
