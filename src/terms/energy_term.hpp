// One contribution to the elastic energy E(x) of a scene: g(x) = 1/2 |x - y|_M^2 + h^2 sum_t E_t(x).
//
// Every kind of element (continuum tets, mass-spring tets, strand segments, cloth) is a term, and
// so are attachments and contact: the scene is the list of them, built alike, and the run asks each
// what it reports through this interface. A term works on the local elements of this rank: it
// adds its local energy and gradient into the body's accumulators, and the body reduces over the
// ranks once for all terms. A scene holds only the terms it uses (model/elastic_terms.hpp), so a
// scene without strands runs no strand code. docs/architecture.md, "Add an energy term".
#pragma once
#include <petscmat.h>

#include <array>
#include <string>
#include <utility>
#include <vector>

#include "terms/element_fields.hpp"
#include "terms/element_state.hpp"

namespace hyperqn {

// What a term learns at the start of every time step (sub-steps included).
struct StepStart {
  double t = 0;          // time at the end of the step
  double dt = 0;         // the step's length h
  Vec x_start = nullptr; // x_n, the positions at its start (global free dofs)
  Vec y = nullptr;       // its inertial target y (global free dofs)
  double t_start = 0;    // the time of x_start (t_n)
  // For terms that couple surfaces (Body::begin_step fills them; null otherwise): the local
  // positions of all local vertices at the step's start (x_n, fixed vertices where they were at
  // t_start) and where the solve starts from (x_n, fixed vertices already at t).
  const std::vector<double>* start_positions = nullptr;
  const std::vector<double>* positions = nullptr;
  bool quasi_static = false;  // a static load step: no inertia bounds a free body's steps
};

// A log file of a term's own (a CSV: "frame,time," then its columns), e.g. contact.csv.
struct TermLog {
  std::string file;     // its name in the output directory ("": the term keeps no log)
  std::string columns;  // CSV header after "frame,time,"
};

// What a term reports at the end of a frame: its log's rows (each the values after frame,time),
// maxima over the run for summary.json (the summary's field name, the frame's value), and flags:
// the frame counted under a summary field (its name) with a sentence for the console, e.g. the
// contact's {"collider_intrusions", "colliders[1] (box, deck line 23) holds 4 vertices ..."}.
struct TermReport {
  std::vector<std::string> rows;
  std::vector<std::pair<std::string, double>> maxima;
  std::vector<std::pair<std::string, std::string>> flags;
};

// What a term finds wrong with the input: the deck line and key it comes from, and what ("": nothing).
struct InputProblem {
  int line = 0;
  std::string key, what;
};

// A 3 x 3 diagonal block of d2E/dx2 (psd) at one free vertex (contact, self-contact and their
// friction): what solver.h0_contact puts into L-BFGS's initial Hessian.
struct VertexStiffness {
  PetscInt dof = 0;            // global index of the vertex's x dof (y, z follow)
  std::array<double, 9> K{};   // symmetric positive semidefinite, row-major
};

// One tet's part of L (A = M + h^2 L) as solver.h0_rigid sees it (solvers/rigid_mode_h0.hpp): its
// vertices (input mesh ids and global x dofs, -1 fixed), its 4 x 4 matrix (scaled, row-major) and
// its material's weight w in L_e = w V G^T G.
struct TetLaplacian {
  std::array<int64_t, 4> vertex{};
  std::array<PetscInt, 4> dof{};
  std::array<double, 16> K{};
  double weight = 0;
};

class EnergyTerm {
 public:
  virtual ~EnergyTerm() = default;
  // What the logs call it, e.g. "corotated, neohookean" or "strand".
  virtual std::string name() const = 0;

  // Adds the term's energy over this rank's elements to *energy (not reduced over ranks) and, if
  // gradient is not null, dE/dx to it: the local (ghosted) array of free dofs, 3 per free local
  // vertex at mesh.local_dof. x is the global vector of free dofs, pos the local positions of all
  // local vertices (fixed ones at their prescribed positions).
  virtual PetscErrorCode add_energy(Vec x, const std::vector<double>& pos, double* energy,
                                    PetscScalar* gradient) const = 0;
  // H += scale * d2E/dx2 at pos on the free dofs (global indices), with the per-element
  // definiteness fix (psd, Newton) or exact (possibly indefinite; tests, the study's reference).
  virtual PetscErrorCode add_hessian(const std::vector<double>& pos, Mat H, double scale, bool psd) const = 0;
  // Its part of the rest stiffness K(x_rest) (solver.h0: rest-stiffness), PSD: a function of the
  // scene alone, so that a matrix built from it is the same whenever it is built (a sub-step's at
  // the first sub-step, a restart's at its frame). add_hessian at the rest positions, but with no
  // step state: a history at its start (inelastic, yielding springs) and no contact (the
  // obstacles' positions now, the lagged friction), which overrides say.
  virtual PetscErrorCode add_rest_stiffness(const std::vector<double>& rest, Mat H, double scale) const {
    return add_hessian(rest, H, scale, true);
  }
  // The 3 x 3 diagonal blocks of add_hessian (psd) at pos, per owned free vertex that has one
  // (appended to out; a vertex may appear more than once); blocks between two vertices are left
  // out. Collective (a term that couples vertices of several ranks sends each block to its owner).
  virtual PetscErrorCode add_vertex_stiffness(const std::vector<double>& /*pos*/, std::vector<VertexStiffness>& /*out*/) const {
    return 0;
  }
  // True if add_vertex_stiffness may add blocks (else L-BFGS's H0 never asks).
  virtual bool has_vertex_stiffness() const { return false; }

  // The term's part of the constant matrix L (A = M + h^2 L): A += scale * L_t, in the dof layout
  // (components = 3) or the vertex layout of mesh.vertex_dm (components = 1, A = A1 (x) I3).
  virtual PetscErrorCode add_laplacian(Mat /*A*/, double /*scale*/, int /*components*/) const { return 0; }
  // This rank's tets' parts of add_laplacian (scaled by scale) whose weight is at least min_weight,
  // appended to out; and the range of all their weights (softest and stiffest lowered and raised).
  // Terms without tets add none.
  virtual void add_tet_laplacians(double /*scale*/, double /*min_weight*/, std::vector<TetLaplacian>& /*out*/) const {}
  virtual void tet_weight_range(double& /*softest*/, double& /*stiffest*/) const {}
  // The term's part of solver.h0: volumetric's matrix, in the dof layout: A += scale * K_t. Terms
  // without a volumetric form (springs, strands, cloth, inelastic tets) add their L.
  virtual PetscErrorCode add_volumetric_h0(Mat A, double scale) const { return add_laplacian(A, scale, 3); }
  // Lumped mass of this rank's elements: added per free dof to mass (local ghosted array), and
  // the total over all of them, fixed vertices included.
  virtual void add_lumped_mass(PetscScalar* /*mass*/) const {}
  virtual double local_mass() const { return 0; }
  // True if the term is exactly a Projective Dynamics energy whose global matrix is its own
  // add_laplacian (so x - A^{-1} grad g is the local-global step and never increases g).
  virtual bool projective_dynamics_exact() const = 0;

  // Called at the start of every time step: moving obstacles, attachments, lagged friction and
  // the like update here.
  virtual PetscErrorCode begin_step(const StepStart& /*step*/) { return 0; }
  // Largest alpha <= *alpha such that x + alpha dir is admissible (e.g. no vertex crosses an
  // obstacle); unbounded terms leave *alpha alone. hyperqn's own backtracking (PD, the retries
  // after failed line searches) starts no further; TAO's line searches do not ask yet (the
  // contact terms, which need it, will bound them through the guarded TAO loop).
  virtual bool bounds_steps() const { return false; }
  // True if the term couples vertices that share no element, through surfaces that come close
  // (self-contact): Newton's Hessian then takes entries outside the mesh's pattern, and, if the
  // term bounds steps, a step's first guess is pulled back to within limit_step of x_n (two
  // primitives that passed through each other are apart again, so their energy alone would not
  // refuse the guess, unlike a vertex inside an obstacle).
  virtual bool couples_surfaces() const { return false; }
  // True for contact (obstacles, self-contact): its forces are the reactions of surfaces, not
  // loads, so a static step's force scale leaves them out (StepObjective::begin_step).
  virtual bool is_contact() const { return false; }
  // True if begin_step needs the step's local positions (StepStart::start_positions, positions):
  // a term that couples surfaces, or one that takes its directions from the step's start (a
  // pressure on an open surface).
  virtual bool needs_step_positions() const { return couples_surfaces(); }
  // Pairs of free vertices (each by its global x dof) that add_hessian may couple outside the
  // mesh's pattern, at pos and at every point until the term's own lists are next rebuilt
  // (self-contact: its candidate pairs and friction pairs), appended to out unless it is null.
  // Adds to *generation a count of those rebuilds (the lists updated at pos first): the couplings
  // change only when it does. Newton's Hessian preallocates them in one go, so that its pattern,
  // and MUMPS's analysis, change only when new ones come (StepObjective::assemble_hessian).
  // Collective.
  virtual PetscErrorCode add_couplings(const std::vector<double>& /*pos*/, std::vector<std::array<PetscInt, 2>>* /*out*/,
                                       unsigned long long* /*generation*/) const {
    return 0;
  }
  // A signature of the term's active set at the last point it evaluated (0: none; contact).
  virtual unsigned long long active_set() const { return 0; }
  // Per-element values the term carries across steps (terms/element_state.hpp), or null. At the
  // end of every accepted step (each of the fallback chain's sub-steps, or the frame's one) the
  // body calls update_state with the accepted local positions, to write the state's current values
  // from its start; an undone step puts the start back (an undone frame, the frame's start). The
  // step's length is t - t_start of the last begin_step (StepStart).
  virtual ElementState* element_state() { return nullptr; }
  virtual PetscErrorCode update_state(const std::vector<double>& /*pos*/) { return 0; }
  // The energy its elements on this rank have dissipated since the run began (J, in the state as
  // it stands; a material with history: docs/inelastic.md#what-a-run-reports), 0 for an elastic term.
  virtual double dissipated_energy() const { return 0; }
  // The largest strain at which its elements' dissipation is a small-strain measure
  // (InelasticModel::small_strain_reach: viscoelastic_prony), -1 where none is.
  virtual double small_strain_reach() const { return -1; }
  // The lumped mass per free dof (global layout, Body::lumped_mass) once the scene knows it, for
  // a term whose parameters scale with the mass (the contact penalty).
  virtual PetscErrorCode set_masses(Vec /*mass*/) { return 0; }

  // What the run reports of the term, asked of every term alike (io/ includes no term):
  // a line for the console at setup ("" none), its own log, the frame's report (collective), and
  // point fields of the output frames (names; one's values at pos into a global vector of free
  // dofs, collective).
  virtual std::string describe() const { return ""; }
  // Whether a run may start at pos, the frame-0 positions of a new run (not of a restart: a run
  // goes on from any state it reached); collective, every rank gets the same problem (e.g. a body
  // inside an obstacle).
  virtual PetscErrorCode check_start(const std::vector<double>& /*pos*/, InputProblem& /*out*/) const { return 0; }
  // Why the term's energy is not finite at pos, for the message of a run that stops there ("": it
  // is, or the term cannot say); collective.
  virtual PetscErrorCode explain_rejection(const std::vector<double>& /*pos*/, std::string& /*why*/) const {
    return 0;
  }
  virtual TermLog log() const { return {}; }
  virtual PetscErrorCode report(const std::vector<double>& /*pos*/, TermReport& /*out*/) const { return 0; }
  virtual std::vector<std::string> point_fields() const { return {}; }
  virtual PetscErrorCode point_field(const std::string& /*name*/, const std::vector<double>& /*pos*/, Vec /*out*/) const {
    return 0;
  }
  // Per-element fields of the output frames (deck output.fields, terms/element_fields.hpp): those
  // the term gives, and their values at pos written at its own elements' places in each of
  // `fields` it gives (local; other elements left alone).
  virtual std::vector<ElementField> element_fields() const { return {}; }
  virtual void fill_element_fields(const std::vector<double>& /*pos*/, std::vector<ElementFieldValues>& /*fields*/) const {}
  virtual PetscErrorCode limit_step(Vec /*x*/, Vec /*dir*/, double* /*alpha*/) const { return 0; }

  // The implicit midpoint's energy check (StepObjective::springs_keep_energy): over this
  // rank's elements, adds to *defect the sum of E_e(end) - E_e(start) - dE_e/dx(z) . (end - start),
  // the energy the step's end map makes beyond the work of the forces at z (0 for an energy
  // quadratic along the step), and to *scale the sum of E_e(start) + E_e(end) + |that work|; local
  // positions, each at its time (fixed vertices at t_n, t_n + h/2, t_{n+1}). Only terms with
  // has_midpoint_defect add anything: strands and cloth (edge and bending springs in closed form,
  // membranes and hinges from their energy, terms/midpoint_defect.hpp).
  virtual bool has_midpoint_defect() const { return false; }
  virtual void add_midpoint_defect(const std::vector<double>& /*start*/, const std::vector<double>& /*z*/,
                                   const std::vector<double>& /*end*/, double* /*defect*/, double* /*scale*/) const {}
};

}  // namespace hyperqn
