#include "app/run_options.hpp"

#include <petscviewer.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <iterator>
#include <sstream>
#include <string>
#include <strings.h>

#include "app/petsc_errors.hpp"
#include "mesh/input_error.hpp"
#include "mesh/text_tokens.hpp"
#include "model/elastic_terms.hpp"
#include "solvers/rigid_mode_h0.hpp"
#include "solvers/solver_registry.hpp"
#include "terms/nan_injection.hpp"

namespace hyperqn {

// The PetscOptionsBegin block itself (PETSc errors on a value that is not a number).
static PetscErrorCode parse_run_options(MPI_Comm comm, RunOptions* o);

// -hyperqn_h0_package's choices, as PetscOptionsEList lists them in -help ("auto" first).
static const char* const kH0Packages[] = {"auto", "mumps", "cholmod", "supernodal", "split"};
static const FactorPackage kH0PackageOf[] = {default_factor_package(), FactorPackage::mumps, FactorPackage::cholmod,
                                             FactorPackage::supernodal, FactorPackage::split};
static constexpr int kH0PackageCount = 5;

std::string log_view_problem(const std::string& value) {
  const size_t first = value.find(':'), second = first == std::string::npos ? first : value.find(':', first + 1);
  if (second == std::string::npos) return "";
  const std::string format = value.substr(second + 1, value.find(':', second + 1) - second - 1);
  if (format.empty()) return "";
  for (int k = 0; PetscViewerFormats[k + 2]; ++k)  // the list ends with the enum's name, its prefix, null
    if (strcasecmp(format.c_str(), PetscViewerFormats[k]) == 0)
      return k == PETSC_VIEWER_ASCII_XML || k == PETSC_VIEWER_ASCII_FLAMEGRAPH
                 ? "the format " + format + " is PETSc's nested log, which hyperqn does not support (summary.json reads "
                   "the default log): use the default format or ascii_info_detail"
                 : "";
  return "unknown viewer format '" + format + "' (e.g. ascii_info_detail)";
}

// A refused value of option `name`: named with its deck line and key when the deck's petsc:
// section gave it (and the command line did not override it), else as the command line's.
[[noreturn]] static void refuse(const Deck* deck, const char* name, const std::string& why) {
  char value[256] = "";
  PetscBool set = PETSC_FALSE;
  PetscOptionsGetString(nullptr, nullptr, name, value, sizeof value, &set);
  if (const Deck::OptionPlace* place = deck ? deck_option_place(*deck, name, value) : nullptr)
    throw InputError(deck->path, place->line, place->key, why + ", got " + value);
  throw InputError(std::string("option ") + name + (value[0] ? std::string(" ") + value : std::string()) + ": " + why);
}

// The options database as (name, value) in its order (PetscOptionsGetAll: "-a 1 -b -c x"; a
// value may be a negative number, "-x -1", "-x -inf"). Read this way, not by PetscOptionsGetString, which
// would mark every option used and silence the run's warning of the options nothing read.
std::vector<std::pair<std::string, std::string>> all_options() {
  char* all = nullptr;
  PetscOptionsGetAll(nullptr, &all);
  std::vector<std::pair<std::string, std::string>> options;
  std::istringstream words(all ? all : "");
  for (std::string w; words >> w;) {
    std::string lower = w;
    for (char& c : lower) c = static_cast<char>(std::tolower((unsigned char)c));
    const bool number = lower == "-inf" || lower == "-infinity" || lower == "-nan";
    const bool name = w.size() > 1 && w[0] == '-' && !std::isdigit((unsigned char)w[1]) && w[1] != '.' && !number;
    if (name) options.push_back({w, ""});
    else if (!options.empty()) options.back().second += (options.back().second.empty() ? "" : " ") + w;
  }
  PetscFree(all);
  return options;
}

// The options parse_run_options reads as numbers: given without a value, PETSc would keep the
// default and say nothing.
static const char* const kNumericOptions[] = {
    "-hyperqn_divergence_limit",         "-hyperqn_element_limit",           "-hyperqn_test_nan_energy_beyond",
    "-hyperqn_test_nan_energy_from_step", "-hyperqn_test_kill_after_frame",  "-hyperqn_test_signal_after_frame",
    "-hyperqn_test_signal_in_frame",     "-hyperqn_test_signal_at_iteration", "-hyperqn_progress_seconds",
    "-hyperqn_rigid_h0_share",           "-hyperqn_test_topology_h0_max_touched", "-hyperqn_test_rank_error_after_frame"};

// strtod reads all of value (inf and nan among what it reads).
static bool strtod_reads(const std::string& value, double* x) {
  char* end = nullptr;
  *x = std::strtod(value.c_str(), &end);
  return end != value.c_str() && *end == '\0';
}

// value is a number strtod reads, and PETSc's PetscOptionsReal with it, but not a plain decimal
// nor inf or nan: hexadecimal (0x10 read as 16, 0x1p3 as 8). Plain decimals as in mesh files
// (parse_double, mesh/text_tokens.hpp).
static bool hexadecimal(const std::string& value) {
  double x;
  const Token t{value.data(), value.data() + value.size(), 0};
  return strtod_reads(value, &x) && std::isfinite(x) && !parse_double(t, x);
}

// value as a whole number: a plain decimal, or inf or nan (which the callers refuse as not
// finite); false for anything else, hexadecimal among it.
static bool number_in(const std::string& value, double* x) { return strtod_reads(value, x) && !hexadecimal(value); }

// A word PETSc's PetscOptionsGetBool reads (true/false, yes/no, on/off, 1/0, any case).
static bool bool_word(const std::string& value) {
  for (const char* w : {"true", "false", "yes", "no", "on", "off", "1", "0"})
    if (strcasecmp(value.c_str(), w) == 0) return true;
  return false;
}

PetscErrorCode read_run_options(MPI_Comm comm, RunOptions* o, const Deck* deck) {
  PetscFunctionBeginUser;
  for (const auto& [name, value] : all_options()) {
    // A value-taking option given without one: hyperqn's numbers and every PETSc *_type (PETSc would
    // keep the default unsaid, or fail later without naming the option).
    const bool number = std::find(std::begin(kNumericOptions), std::end(kNumericOptions), name) != std::end(kNumericOptions);
    const bool type = name.size() > 5 && name.compare(name.size() - 5, 5, "_type") == 0;
    if (value.empty() && (number || type)) refuse(deck, name.c_str(), number ? "needs a value (a number)" : "needs a value (a type's name)");
    // Hexadecimal: PETSc's reals take it (strtod: -hyperqn_divergence_limit 0x10 ran with 16), its
    // integers do not; refused alike for every number option hyperqn reads or checks.
    const bool checked = name == "-tao_gatol" || name == "-tao_grtol" || name == "-tao_gttol" || name == "-tao_max_it" ||
                         name == "-tao_lmvm_mat_lmvm_hist_size";
    if ((number || checked) && hexadecimal(value))
      refuse(deck, name.c_str(), "hexadecimal is not taken: a number is a plain decimal (16, 1.5e-3)");
    // Read by the rigid-mode H0 when a scene has one: checked here, so that config and every run refuse it alike.
    double x = 0;
    if (name == "-hyperqn_rigid_h0_share" && !(number_in(value, &x) && x > 0 && x <= 1))
      refuse(deck, name.c_str(), "must be a number in (0, 1]");
    // TAO's tolerances and budget, and the L-BFGS history, as given: TAO takes any number (nan and
    // negative tolerances never stop a frame, inf stops each at once; 2147483648 wraps to a
    // negative budget, 4294967297 to 1) and PETSc crashes on a negative history. Checked here, so
    // that config and every run refuse them alike, quoting the value as written.
    const auto whole_in = [&](double hi) { return number_in(value, &x) && x >= 0 && x <= hi && x == std::floor(x); };
    if ((name == "-tao_gatol" || name == "-tao_grtol" || name == "-tao_gttol") && !value.empty() &&
        !(number_in(value, &x) && std::isfinite(x) && x >= 0))
      refuse(deck, name.c_str(), "must be a finite number >= 0 (the solver's tolerance)");
    if (name == "-tao_max_it" && !value.empty() && !whole_in(2147483647.0))
      refuse(deck, name.c_str(), "must be a whole number from 0 to 2147483647 (0: the fallback chain's stages alone iterate)");
    if (name == "-tao_lmvm_mat_lmvm_hist_size" && !value.empty() && !whole_in(kMaxHistory))
      refuse(deck, name.c_str(), "the L-BFGS history must be a whole number in [0, " + std::to_string(kMaxHistory) + "]");
    // -restart (one -) from an options file, PETSC_OPTIONS or the deck: nothing reads it, and the
    // run would start afresh, removing the run it was meant to continue (--restart is the command
    // line's, which PETSc lists as the option --restart).
    if (name == "-restart") refuse(deck, name.c_str(), "is not an option: a restart is the command line's --restart VALUE");
    // Flags read as bools: a word PETSc does not read as one would stop the run with PETSc's error.
    if (name == "-hyperqn_memory_report" && !value.empty() && !bool_word(value))
      refuse(deck, name.c_str(), "must be true or false (or given alone, meaning true)");
  }
  // -mat_type would retype every matrix PETSc makes for hyperqn (the constant matrix, Newton's
  // Hessian) through DMCreateMatrix; several types crash in its preallocation (dense, is).
  for (const char* name : {"-mat_type", "-dm_mat_type"}) {
    PetscBool set;
    PetscCall(PetscOptionsHasName(nullptr, nullptr, name, &set));
    if (set)
      refuse(deck, name, "is not an option of hyperqn: the matrices' formats are its own (the constant matrix's is "
                         "chosen by solver.h0 and linear_solver, docs/deck-run.md); leave it out");
  }
  // Viewer options (-log_view, -tao_view, ...): opened here once, so that a value PETSc cannot
  // open ("true", a file in a missing directory) is an input error before anything is written,
  // not a PETSc error after the run (-log_view is read at PetscFinalize).
  for (const auto& [name, value] : all_options()) {
    const bool viewer = name.size() > 5 && name.compare(name.size() - 5, 5, "_view") == 0;
    if (!viewer) continue;
    if (name == "-log_view")
      if (const std::string problem = log_view_problem(value); !problem.empty()) {
        try {
          refuse(deck, name.c_str(), problem);
        } catch (const InputError&) {
          PetscOptionsClearValue(nullptr, name.c_str());  // PetscFinalize would view it
          throw;
        }
      }
    PetscViewer v = nullptr;
    PetscViewerFormat format;
    PetscBool set = PETSC_FALSE;
    std::string failure;
    {
      PetscErrors errors;
      if (PetscOptionsGetViewer(comm, nullptr, nullptr, name.c_str(), &v, &format, &set)) failure = errors.message();
    }
    if (v) PetscCall(PetscViewerDestroy(&v));
    if (!failure.empty()) {
      try {
        refuse(deck, name.c_str(), "not a viewer PETSc can open (PETSc: " + failure + "); give the option alone "
                                   "(true in a deck) for the screen, or ascii:FILE");
      } catch (const InputError&) {
        PetscOptionsClearValue(nullptr, name.c_str());  // PetscFinalize would fail on -log_view again
        throw;
      }
    }
    // Set again, unread: an option nothing else reads is still warned of.
    PetscCall(PetscOptionsClearValue(nullptr, name.c_str()));
    PetscCall(PetscOptionsSetValue(nullptr, name.c_str(), value.empty() ? nullptr : value.c_str()));
  }
  {  // checked first, for a message that names the choices (PETSc's would not)
    char value[64] = "";
    PetscBool set = PETSC_FALSE, known = PETSC_FALSE;
    PetscCall(PetscOptionsGetString(nullptr, nullptr, "-hyperqn_h0_package", value, sizeof value, &set));
    for (const char* choice : kH0Packages) {
      PetscBool same;
      PetscCall(PetscStrcasecmp(value, choice, &same));
      known = (PetscBool)(known || same);
    }
    if (set && !known)
      refuse(deck, "-hyperqn_h0_package", "unknown package (choose auto, mumps, cholmod, supernodal or split)");
    PetscBool cholmod;
    PetscCall(PetscStrcasecmp(value, "cholmod", &cholmod));
    if (set && cholmod && !factor_package_available(FactorPackage::cholmod))
      throw InputError("option -hyperqn_h0_package cholmod: this PETSc was built without SuiteSparse, so it has no "
                       "CHOLMOD (use supernodal, mumps or auto)");
  }
  if (deck) {  // the deck's limits, unless the options set them
    o->divergence_limit = deck->guardrails.divergence_limit;
    o->element_limit = deck->guardrails.element_limit;
  }
  PetscErrors errors;  // a value that is not a number: said as an input error, not a trace
  if (parse_run_options(comm, o)) throw InputError(deck ? errors.describe(*deck) : errors.describe());
  if (deck && deck->solver.h0_precision == H0Precision::single_precision &&
      (o->h0_package == FactorPackage::mumps || o->h0_package == FactorPackage::cholmod))
    refuse(deck, "-hyperqn_h0_package",
           "solver.h0_precision: single is solved by hyperqn's own loops (choose auto, supernodal or split)");
  // Every rank reads the same options, so every rank throws alike.
  if (!std::isfinite(o->divergence_limit))
    refuse(deck, "-hyperqn_divergence_limit", "must be a finite number (<= 0 turns the check off)");
  if (!std::isfinite(o->element_limit))
    refuse(deck, "-hyperqn_element_limit", "must be a finite number (<= 0 turns the check off)");
  if (!std::isfinite(o->nan_beyond)) refuse(deck, "-hyperqn_test_nan_energy_beyond", "must be a finite number");
  if (!std::isfinite(o->progress_seconds))
    refuse(deck, "-hyperqn_progress_seconds", "must be a finite number of seconds (<= 0: no progress lines)");
  PetscFunctionReturn(0);
}

PetscErrorCode parse_run_options(MPI_Comm comm, RunOptions* o) {
  PetscFunctionBeginUser;
  PetscOptionsBegin(comm, nullptr, "hyperqn options", "hyperqn");
  PetscCall(PetscOptionsReal(kNumericOptions[0],
                             "Stop the run when an element edge is longer than this many rest bounding-box diagonals "
                             "(<= 0: never)", "docs/guardrails.md", o->divergence_limit, &o->divergence_limit, nullptr));
  PetscCall(PetscOptionsReal(kNumericOptions[1],
                             "Stop the run when an element's |det F| exceeds this (<= 0: never)", "docs/guardrails.md",
                             o->element_limit, &o->element_limit, nullptr));
  PetscCall(PetscOptionsReal(kNumericOptions[2],
                             "Tests only: g = NaN where ||x - y||_inf exceeds this distance (< 0: off)",
                             "terms/nan_injection.hpp", o->nan_beyond, &o->nan_beyond, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[3],
                            "Tests only: g = NaN everywhere from this time step of a scene on (< 0: off)",
                            "terms/nan_injection.hpp", o->nan_from_step, &o->nan_from_step, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[4],
                            "Tests only: every rank kills itself (SIGKILL) once this frame is done (< 0: off)",
                            "docs/outputs.md", o->kill_after_frame, &o->kill_after_frame, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[5],
                            "Tests only: every rank sends itself SIGTERM after this frame (0: during setup; < 0: off)",
                            "docs/outputs.md", o->signal_after_frame, &o->signal_after_frame, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[6],
                            "Tests only: the last rank sends itself SIGTERM during this frame's solve (< 0: off)",
                            "docs/outputs.md", o->signal_in_frame, &o->signal_in_frame, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[7],
                            "Tests only: with -hyperqn_test_signal_in_frame, after this many iterations of that frame "
                            "(every stage of the fallback chain counted)",
                            "docs/outputs.md", o->signal_at_iteration, &o->signal_at_iteration, nullptr));
  PetscCall(PetscOptionsReal(kNumericOptions[8],
                             "A frame whose solve has run this many seconds prints a progress line (iteration, g, "
                             "|grad g|), and again every as many seconds (<= 0: never)",
                             "docs/outputs.md", o->progress_seconds, &o->progress_seconds, nullptr));
  PetscCall(PetscOptionsInt(kNumericOptions[11],
                            "Tests only: the last rank alone fails (a PETSc error) after this frame (< 0: off)",
                            "docs/guardrails.md", o->rank_error_after_frame, &o->rank_error_after_frame, nullptr));
  PetscInt package = 0;  // auto
  for (int k = 1; k < kH0PackageCount; ++k)
    if (o->h0_package == kH0PackageOf[k] && o->h0_package != default_factor_package()) package = k;
  const std::string help =
      "Sparse Cholesky that factors and solves the constant matrix M + h^2 L (or M + h^2 K): auto (supernodal on one "
      "rank; on more, split while its interface block has at most " + std::to_string(kMaxSplitInterface) +
      " rows, else supernodal), supernodal (CHOLMOD's factor, hyperqn's solve with x, y, z interleaved; gathered to "
      "rank 0 on more than one), split (supernodal distributed: each rank's interior and a dense Schur complement of "
      "the rank interface), mumps or cholmod (through PETSc, gathered to rank 0; options with the prefix h0_: "
      "-h0_mat_mumps_*, -h0_mat_cholmod_*)";
  PetscCall(PetscOptionsEList("-hyperqn_h0_package", help.c_str(), "docs/performance.md", kH0Packages,
                              kH0PackageCount, kH0Packages[package], &package, nullptr));
  o->h0_package = kH0PackageOf[package];
  // Options read where they act, listed here for -help only (so that a run's warning of options
  // nothing read still sees them unread). test_log_view.py checks that -help lists every
  // -hyperqn_ option of the source.
  PetscBool listing = PETSC_FALSE;
  PetscCall(PetscOptionsHasHelp(nullptr, &listing));
  if (listing) {
    PetscBool b = PETSC_TRUE;
    PetscReal share = RigidModeH0::kRemovedShare;
    PetscInt touched = 0;
    PetscCall(PetscOptionsBool("-hyperqn_topology_h0", "Cuts, fracture, snaps and tears correct the constant matrix's "
                               "factor (TopologyH0) where they can; false factors it again at every change",
                               "docs/topology.md", b, &b, nullptr));
    PetscCall(PetscOptionsBool("-hyperqn_memory_report", "Print every rank's memory estimate by parts, and its limit",
                               "docs/guardrails.md", PETSC_FALSE, &b, nullptr));
    PetscCall(PetscOptionsName("-hyperqn_h0_matrix_view", "View the constant matrix as factored (a PETSc viewer: "
                               "binary:A1.bin)", "docs/performance.md", &b));
    PetscCall(PetscOptionsReal("-hyperqn_rigid_h0_share", "solver.h0_rigid: the share of the stiff clusters' charge on "
                               "their rotations removed from H0, in (0, 1]", "docs/method.md", share, &share, nullptr));
    PetscCall(PetscOptionsName("-hyperqn_test_topology_h0_check", "Tests only: after each change, the corrected H0 "
                               "against a fresh factorization", "docs/topology.md", &b));
    PetscCall(PetscOptionsName("-hyperqn_test_topology_h0_drop_edit", "Tests only: drop one edit of the correction "
                               "(the check must see it)", "docs/topology.md", &b));
    PetscCall(PetscOptionsInt("-hyperqn_test_topology_h0_max_touched", "Tests only: the correction's size trigger "
                              "(vertices touched before the factor is made again; 0: the default)", "docs/topology.md",
                              touched, &touched, nullptr));
    PetscCall(PetscOptionsName("-hyperqn_test_rigid_h0_check", "Tests only: the rigid-mode H0 against a dense solve "
                               "on random vectors (small scenes)", "docs/method.md", &b));
  }
  PetscOptionsEnd();
  PetscFunctionReturn(0);
}

double h0_poisson_ratio(const Deck& deck) {
  return deck.solver.h0_contact == H0Contact::woodbury ? 0.0 : largest_poisson_ratio(deck);
}

double held_still_weight(const Deck& deck) {
  const double g = std::hypot(deck.gravity[0], deck.gravity[1], deck.gravity[2]);
  if (!(g > 0) || deck.fixed.empty() || !deck.bodies.empty() || !deck.loads.empty() || !deck.attachments.empty() ||
      !deck.colliders.empty() || deck.contact.self || !deck.cuts.empty() || deck.initial.kind != InitialKind::rest ||
      deck.time.integrator == TimeIntegrator::quasi_static)
    return 0;
  for (const BoxRegion& f : deck.fixed)
    if (f.motion.active || f.release >= 0 || is_roller(f)) return 0;
  return g * largest_density_over_modulus(deck);
}

SceneOptions scene_options(const Deck& deck, const RunOptions& o, const std::vector<std::string>& solvers) {
  SceneOptions s;
  for (const std::string& type : solvers) {
    if (!solver_uses_constant_matrix(type)) continue;
    SolverSpec spec = deck.solver;
    spec.type = type;
    s.h0s.push_back(solver_h0(spec));
  }
  s.poisson_ratio = h0_poisson_ratio(deck);
  s.held_weight = held_still_weight(deck);
  s.h0_package = o.h0_package;
  s.h0_precision = deck.solver.h0_precision;
  s.warm_start = deck.solver.warm_start;
  s.upright_guess = deck.solver.upright_guess;
  s.element_limit = o.element_limit;
  if (o.nan_beyond >= 0 || o.nan_from_step >= 0)
    s.extra_terms = [o](const DistributedMesh&, std::vector<std::unique_ptr<EnergyTerm>>& terms) {
      terms.push_back(std::make_unique<NanInjection>(o.nan_beyond, o.nan_from_step));
    };
  return s;
}

}  // namespace hyperqn
