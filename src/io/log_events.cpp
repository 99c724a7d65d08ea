#include "io/log_events.hpp"

#include <petscdm.h>
#include <petscksp.h>
#include <petsctao.h>

namespace hyperqn {

static LogEvents register_events() {
  LogEvents e;
  PetscClassId id;
  // The summary reads the events' times: logging is on in every run, -log_view or not. Without
  // -log_view only hyperqn's own events are logged: PETSc's vector and matrix operations run about
  // 66 times per L-BFGS iteration, and logging each costs a few percent on small meshes.
  PetscBool log_view;
  PetscCallAbort(PETSC_COMM_WORLD, PetscLogDefaultBegin());
  PetscCallAbort(PETSC_COMM_WORLD, PetscOptionsHasName(nullptr, nullptr, "-log_view", &log_view));
  if (!log_view) {
    // Deactivating a class reaches only the events registered so far: register them all first.
    for (auto init : {VecInitializePackage, MatInitializePackage, DMInitializePackage, KSPInitializePackage,
                      PCInitializePackage, TaoInitializePackage, TaoLineSearchInitializePackage})
      PetscCallAbort(PETSC_COMM_WORLD, init());
    for (PetscClassId petsc : {VEC_CLASSID, MAT_CLASSID, PETSCSF_CLASSID, IS_CLASSID, DM_CLASSID,
                               KSP_CLASSID, PC_CLASSID, TAO_CLASSID, TAOLINESEARCH_CLASSID})
      PetscCallAbort(PETSC_COMM_WORLD, PetscLogEventDeactivateClass(petsc));
  }
  PetscCallAbort(PETSC_COMM_WORLD, PetscClassIdRegister("hyperqn", &id));
  const auto add = [id](const char* name, PetscLogEvent* event) {
    PetscCallAbort(PETSC_COMM_WORLD, PetscLogEventRegister(name, id, event));
  };
  add("hqnObjective", &e.objective);
  add("hqnHessian", &e.hessian);
  add("hqnH0Assembly", &e.h0_assembly);
  add("hqnH0Factor", &e.h0_factor);
  add("hqnH0Correct", &e.h0_correct);
  add("hqnH0Solve", &e.h0_solve);
  add("hqnH0Interface", &e.h0_interface);
  add("hqnTwoLoop", &e.two_loop);
  add("hqnStep", &e.step);
  add("hqnBacktrack", &e.backtrack);
  add("hqnScene", &e.scene);
  add("hqnOutput", &e.output);
  add("hqnFields", &e.fields);
  add("hqnContact", &e.contact);
  add("hqnSelfContact", &e.self_contact);
  add("hqnSelfGather", &e.self_gather);
  add("hqnSelfPairs", &e.self_pairs);
  add("hqnCheckpoint", &e.checkpoint);
  add("hqnTopology", &e.topology);
  return e;
}

const LogEvents& log_events() {
  static const LogEvents events = register_events();
  return events;
}

PetscErrorCode event_begin(PetscLogEvent LogEvents::*event) {
  const PetscLogEvent e = log_events().*event;
  return PetscLogEventBegin(e, 0, 0, 0, 0);
}

PetscErrorCode event_end(PetscLogEvent LogEvents::*event) {
  const PetscLogEvent e = log_events().*event;
  return PetscLogEventEnd(e, 0, 0, 0, 0);
}

double event_seconds(PetscLogEvent event) {
  PetscEventPerfInfo info;
  PetscCallAbort(PETSC_COMM_WORLD, PetscLogEventGetPerfInfo(PETSC_DETERMINE, event, &info));
  return info.time;
}

int event_count(PetscLogEvent event) {
  PetscEventPerfInfo info;
  PetscCallAbort(PETSC_COMM_WORLD, PetscLogEventGetPerfInfo(PETSC_DETERMINE, event, &info));
  return info.count;
}

}  // namespace hyperqn
