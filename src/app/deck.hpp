// A scene deck: one YAML file describing one simulation (mesh, material, constraints,
// time stepping, solver, output, extra PETSc options). The format is documented in docs/decks.md.
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace hyperqn {

struct MeshSpec {
  std::string file;                  // .mesh (Medit) or .msh (Gmsh); resolved relative to the deck
  bool is_box = false;               // generated box instead of a file
  std::array<double, 3> box_size{1, 1, 1};
  std::array<int, 3> box_cells{1, 1, 1};
  MeshTransform transform;           // applied to the file or box mesh (not to the strands below)
  bool edges_as_strands = false;     // Medit file: its Edges section becomes strand segments
  std::vector<StrandLine> strands;   // generated strands, world coordinates, after the transform
  bool has_strands() const { return edges_as_strands || !strands.empty(); }
  bool has_solid() const { return is_box || !file.empty(); }
};

// The material of all strand segments: a segment of rest length L stores
// E = EA/(2L) (l - L)^2 = L/2 EA (l/L - 1)^2 and carries linear_density * L of mass.
struct StrandMaterial {
  double axial_stiffness = 0;        // EA: force per unit strain (N)
  double linear_density = 0;         // mass per unit rest length (kg/m)
  double laplacian_weight = 0;       // 0: EA builds L (exact); > 0: this value in its place
};

// A scalar function of the principal-stretch materials: polynomial coefficients c_k of (x - 1)^k,
// or a monotone cubic spline through control points (x_i, y_i) of its derivative.
struct FunctionSpec {
  std::string kind;                  // "" (absent) | polynomial | spline
  std::vector<double> coefficients, x, y;
};

struct MaterialSpec {
  std::string model = "corotated";   // corotated | neohookean | stvk | principal-stretch | mass-spring
  double mu = 0, lambda = 0;         // Lame parameters (from E, nu if those were given)
  double kappa = 0;                  // stvk: compression term kappa (1 - J)^3 / 2592 for J < 1
  double spring_stiffness = 0;       // mass-spring: k of the spring on each edge of each tet
  FunctionSpec f, g, h;              // principal-stretch: psi = sum f(s_i) + sum g(s_i s_j) + h(J)
  bool has_fiber = false;            // fibre term k/2 (|F d| - 1)^2 on top of the model
  std::array<double, 3> fiber_direction{1, 0, 0};
  double fiber_stiffness = 0;
  bool has_density = false;
  double density = 1000;             // mass per unit volume, or
  double total_mass = 0;             // total mass (used when has_density is false)
  double J0 = 0.1;                   // Neo-Hookean: start of the quadratic extension of log J
  double laplacian_weight = 0;       // 0: the material's own weight (mass-spring: k); > 0: override
};

// Prescribed motion of a fixed region: rotation about an axis through a centre at a constant
// rate, plus a translation at a constant velocity, both active for t in [start, end] and held
// afterwards. Position at time t: c + R(rate * tau) (X - c) + velocity * tau,
// tau = clamp(t, start, end) - start.
struct Motion {
  bool active = false;
  std::array<double, 3> axis{1, 0, 0}, center{0, 0, 0};
  double rate_deg = 0;               // degrees per unit time
  std::array<double, 3> velocity{0, 0, 0};
  double start = 0, end = 1e300;
};

struct BoxRegion {
  std::array<double, 3> min{0, 0, 0}, max{0, 0, 0};
  int line = 0;                      // deck line, for error messages
  Motion motion;                     // fixed regions only
  double release = -1;               // fixed regions: time at which its vertices become free (< 0: never)
};

// Elements with a material other than the deck's default one: those whose centroid lies in a
// box, or whose mesh element tag is listed. Later regions override earlier ones.
struct MaterialRegion {
  bool by_box = true;
  BoxRegion box;
  std::vector<int> tags;
  MaterialSpec material;
  int line = 0;
};

struct TimeSpec {
  double dt = 1.0 / 30.0;
  int frames = 100;
  double damping = 0;                // v <- (1 - damping) v after each step
};

struct SolverSpec {
  std::string type = "lbfgs";        // lbfgs | lbfgs-identity | newton | pd
  int iterations = 10;               // per frame
  double grad_atol = 0;              // stop when ||grad g|| <= grad_atol, or
  double grad_rtol = 1e-6;           //   ||grad g|| <= grad_rtol * ||grad g(x0)||
  int history = 5;                   // L-BFGS pairs
  std::string line_search = "more-thuente";  // TAO line search type: more-thuente | armijo | unit
  std::string warm_start = "inertial";       // inertial (x0 = y) | previous (x0 = x_n)
  std::string newton_method = "nls";         // newton: TAO method, nls | ntr
  std::string linear_solver = "mumps";       // newton: mumps (Cholesky) | cg-amg (CG + BoomerAMG)
  std::string newton_hessian = "projected";  // newton: projected (PSD fix per element) | exact
};

// The error-against-time study (hyperqn study DECK): at each of `frames`, every solver in
// `solvers` starts from the same state; a converged Newton solve gives the reference g*.
struct StudySpec {
  std::vector<int> frames{1};
  std::vector<std::string> solvers{"lbfgs", "lbfgs-identity", "pd", "newton"};
  int iterations = 200;              // cap per solver and frame in the per-frame study
  double time_limit = 60;            // seconds per solver and frame
  double reference_rtol = 1e-10;     // reference Newton: ||grad g|| <= reference_rtol ||grad g(x0)||
  bool trajectory = true;            // also compare whole trajectories against converged Newton
  std::map<std::string, int> trajectory_iterations;  // per solver; default solver.iterations
};

struct OutputSpec {
  std::string directory;             // "" -> output/<deck name>
  int every = 1;                     // write VTK every N frames (frame 0 = initial state is always written)
  bool vtk = true;
  bool iterations_csv = true;
};

// An extreme initial state (positions at frame 0; the rest shape stays the mesh). c is the
// centre of the rest bounding box; fixed vertices stay where they are.
struct InitialSpec {
  std::string kind;                  // "" (rest) | squash | collapse | random | invert
  int axis = 1;                      // squash, invert: the coordinate axis (0, 1, 2)
  double factor = 0;                 // squash: x_A = c_A + factor (X_A - c_A)
  long seed = 1;                     // random: uniform in the rest bounding box, per vertex id
};

struct Deck {
  std::string path;                  // the deck file
  std::string name;                  // deck file name without directory and extension
  MeshSpec mesh;
  MaterialSpec material;                 // the default material (of the tets)
  bool has_material = false;             // material given (needed iff the mesh has tets)
  StrandMaterial strand_material;        // of the strand segments (if the mesh has any)
  std::vector<MaterialRegion> regions;   // per-region materials
  std::vector<BoxRegion> fixed;
  InitialSpec initial;
  std::array<double, 3> gravity{0, -9.81, 0};
  TimeSpec time;
  SolverSpec solver;
  OutputSpec output;
  StudySpec study;
  std::vector<std::pair<std::string, std::string>> petsc_options;  // "-key", "value" (petsc: section)
};

// Parses and validates a deck. Unknown keys, wrong types and impossible values throw
// InputError naming the file, line and dotted key.
Deck load_deck(const std::string& path);

}  // namespace hyperqn
