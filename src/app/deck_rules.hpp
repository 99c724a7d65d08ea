// The deck's rules between sections (app/deck_rules.cpp): each a check or a default that one
// section's value depends on another's.
#pragma once
#include "app/deck.hpp"
#include "app/deck_reader.hpp"

namespace hyperqn::deck_reading {

// Colliders or self-contact.
bool has_contact(const Deck& deck);
// contact: describes touching colliders or the body itself: without either it would say nothing.
void check_contact_has_surfaces(const Reader& r, const Value& contact, const Deck& deck);
// A cloth's thickness acts in self-contact only: without it the key would say nothing.
void check_thickness_in_self_contact(const Reader& r, const Deck& deck);
// A face_tag (fixed, loads) needs the deck's one mesh file, a Medit or Gmsh file of tets.
void check_face_tags_have_a_file(const Reader& r, const Deck& deck);
// Colliders and self-contact need an integrator whose end of step is the solve's z (which the
// barrier kept free of intersections): time.integrator, and each of study.integrators.
void check_integrator_takes_contact(const Reader& r, const Value& time, const Deck& deck);
// A static scene needs something that holds it (a fixed region, an attachment or a collider): with
// none, no equilibrium exists under loads, and none is unique without them.
void check_static_has_support(const Reader& r, const Value& time, const Deck& deck);
// output.energy: not with contact, whose work energy.csv does not count yet.
void check_energy_output(const Reader& r, const Value& output, const Deck& deck);
void check_fields_have_frames(const Reader& r, const Value& output, const Deck& deck);
// cuts: (read) against the mesh.
void check_cuts(const Reader& r, const Value& cuts, const Deck& deck);
void check_fracture(const Reader& r, const Deck& deck);
void check_study_integrators_take_contact(const Reader& r, const Value& study, const Deck& deck);
// With contact, the solver keys the deck leaves out take their contact defaults
// (kContactSolverDefaults, solvers/solver_spec.hpp), read as if the deck wrote them; each is
// recorded in deck.rule_sources. solver: the deck's solver section, if any.
void apply_contact_solver_defaults(const Reader& r, const Value* solver, Deck& deck);

// Rollers (a fixed region with `components`, model/regions.hpp): lbfgs's H0 is a factor whose held
// rows are the identity's, which one V-cycle of A1 cannot be: solver.h0: amg is an error, and an
// automatic h0 is the Laplacian's factor (recorded in deck.rule_sources). solver: as above.
void apply_roller_solver_rules(const Reader& r, const Value* solver, Deck& deck);

}  // namespace hyperqn::deck_reading
