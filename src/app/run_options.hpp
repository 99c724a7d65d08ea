// hyperqn's own PETSc options (-hyperqn_*), declared in one PetscOptionsBegin block so that
// -help lists them with their defaults, and what the deck and these options make of a scene's
// build (the guardrail tests' NaN injection is a term the scene then holds).
#pragma once
#include <petscsys.h>

#include <string>
#include <utility>
#include <vector>

#include "app/deck.hpp"
#include "model/scene.hpp"

namespace hyperqn {

struct RunOptions {
  // The guardrails' limits (GuardrailSpec, app/deck.hpp): the deck's guardrails: section, or
  // these defaults without a deck; -hyperqn_divergence_limit and -hyperqn_element_limit override.
  PetscReal divergence_limit = GuardrailSpec{}.divergence_limit;
  PetscReal element_limit = GuardrailSpec{}.element_limit;
  // Test hooks (tests/python/test_guardrails.py, terms/nan_injection.hpp): g = NaN where
  // ||x - y||_inf > nan_beyond, or from the nan_from_step-th step on (< 0: off).
  PetscReal nan_beyond = -1;
  PetscInt nan_from_step = -1;
  // Test hooks (tests/python/test_checkpoint_faults.py): each rank kills itself with SIGKILL once
  // frame N is done (its checkpoint included), as kill -9 would; or sends itself SIGTERM after
  // frame N (0: during setup), as a batch system would (< 0: off).
  PetscInt kill_after_frame = -1, signal_after_frame = -1;
  // Test hook (tests/python/test_interrupt.py): the last rank alone sends itself SIGTERM after
  // signal_at_iteration iterations of frame signal_in_frame's solve, every stage of the fallback
  // chain counted, as a batch system's signal that reaches one rank first (< 0: off).
  PetscInt signal_in_frame = -1, signal_at_iteration = 1;
  // Test hook (tests/python/test_interrupt.py): the last rank alone fails (a PETSc error) after
  // this frame, as an error one rank's check finds; the others are left in a collective (< 0: off).
  PetscInt rank_error_after_frame = -1;
  // A frame whose solve has run this long prints a progress line (rank 0), and again each time
  // this much more has passed (<= 0: never). Fast frames print nothing.
  PetscReal progress_seconds = 2.0;
  // Who factors and solves the constant matrices M + h^2 L and M + h^2 K(x_rest)
  // (-hyperqn_h0_package: auto, supernodal, split, mumps or cholmod; auto is default_factor_package(),
  // resolved by choose_factor_package).
  FactorPackage h0_package = default_factor_package();
};

// Reads the options (collective). With -help, PETSc prints them. Throws InputError for a value
// that makes no sense (not finite, not one of the choices, a package this PETSc does not have),
// naming the deck's line and key when `deck` is given and its petsc: section gave the value.
PetscErrorCode read_run_options(MPI_Comm comm, RunOptions* options, const Deck* deck = nullptr);

// What -log_view's value (type:file:format:mode) asks that hyperqn cannot give, "" if nothing: an
// unknown format (PETSc would fail as it starts), or a nested log (ascii_xml, ascii_flamegraph:
// its handlers are replaced by the default log that summary.json reads, and PETSc failed or
// crashed as the program ended). Read before PETSc starts, and from the deck.
std::string log_view_problem(const std::string& value);

// The options database as (name, value) in its order (names with their '-'; a flag's value ""),
// read without marking any used.
std::vector<std::pair<std::string, std::string>> all_options();

// The Poisson ratio by which solver.h0: auto resolves for this deck (resolved_h0): the scene's
// largest (largest_poisson_ratio), or 0 with solver.h0_contact: woodbury, which adds the contacts'
// stiffness to M + h^2 L only (so auto stays there).
double h0_poisson_ratio(const Deck& deck);

// For a scene held still, |g| rho / E (1/m; largest_density_over_modulus), by which solver.h0:
// auto takes the rest stiffness once the mesh gives its size (resolved_h0); 0 for any other scene.
// Held still: gravity, one body of plain hyperelastic tet materials, held by fixed regions that
// neither move, nor let go, nor hold only some components; nothing else on it (no loads,
// attachments, colliders, self-contact, cuts, initial state) and a dynamic integrator. Such a
// scene cannot turn far: a small self-weight deflection keeps it near its rest shape.
double held_still_weight(const Deck& deck);

// How the scene of this deck is built for these solvers (with the deck's solver settings): the
// constant matrices they factor (M + h^2 L, or M + h^2 K(x_rest) for lbfgs with solver.h0:
// rest-stiffness, M + h^2 K_vol with volumetric, or M + h^2 L's V-cycle for h0: amg; auto by
// h0_poisson_ratio and the mesh), the deck's warm start, and the test hooks' term if one is asked for.
SceneOptions scene_options(const Deck& deck, const RunOptions& options, const std::vector<std::string>& solvers);

}  // namespace hyperqn
