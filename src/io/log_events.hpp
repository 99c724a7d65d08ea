// hyperqn's phases as PETSc log events, so -log_view lists them beside PETSc's own, and the run's
// summary reads its timings from them (one measurement of each phase). Registering them switches
// PETSc's logging on.
#pragma once
#include <petsclog.h>

namespace hyperqn {

struct LogEvents {
  PetscLogEvent objective;    // g and grad g at one point (all energy terms)
  PetscLogEvent hessian;      // Newton: assembling M + h^2 K(x)
  PetscLogEvent h0_assembly;  // assembling A1 = M1 + h^2 L1
  PetscLogEvent h0_factor;    // its Cholesky factorization
  PetscLogEvent h0_correct;   // instead of it after a cut: the change as TopologyH0's correction (docs/topology.md)
  PetscLogEvent h0_solve;     // one A^{-1} b (3 right-hand sides)
  PetscLogEvent h0_interface; // within it, the split factor's interface: its Allreduce and dense solve
  PetscLogEvent two_loop;     // solver.two_loop streamed: its passes over the pairs (not its H0 solve)
  PetscLogEvent step;         // one time step's solve (solver iterations, line searches)
  PetscLogEvent backtrack;    // hyperqn's own backtracking line search (PD, retries after failures)
  PetscLogEvent scene;        // building a scene (distribution, terms, integrator, factorization)
  PetscLogEvent output;       // writing one output frame
  PetscLogEvent fields;       // within it, computing the frame's element fields (output.fields)
  PetscLogEvent contact;      // contact and friction: energy, gradient, Hessian, per-step update
  PetscLogEvent self_contact; // self-contact: energy, gradient, Hessian, step bound (its gather included)
  PetscLogEvent self_gather;  // within it, gathering the surface's positions to every rank and the
                              // exchange of the gradients at vertices of other ranks
  PetscLogEvent self_pairs;   // within it, building the candidate pairs (once per step and when the surface moves)
  PetscLogEvent checkpoint;   // writing one checkpoint (rank 0 writes, the others send their rows)
  PetscLogEvent topology;     // scripted cuts: finding the faces a blade crossed, separating them, and
                              // the rebuild that follows (never begun in a deck without cuts)
};

// The events, registered on first use.
const LogEvents& log_events();
// Begin and end of one of them, e.g. event_begin(&LogEvents::objective). (PETSc's macros test
// whether logging is on before they evaluate their argument, so the first use must not be inside
// one: these register first.)
PetscErrorCode event_begin(PetscLogEvent LogEvents::*event);
PetscErrorCode event_end(PetscLogEvent LogEvents::*event);

// Time (s) and count of an event on this rank, in the current logging stage.
double event_seconds(PetscLogEvent event);
int event_count(PetscLogEvent event);

}  // namespace hyperqn
