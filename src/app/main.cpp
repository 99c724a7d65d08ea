// hyperqn: implicit Euler for elastic solids as energy minimization, solved per time step by
// L-BFGS whose initial Hessian is the once-factored M + h^2 L (Liu, Bouaziz & Kavan 2017).
//
//   mpiexec -n N hyperqn DECK.yaml [-o OUTDIR] [PETSc options...]
//   mpiexec -n N hyperqn study DECK.yaml [-o OUTDIR] [PETSc options...]
#include <petscsys.h>

#include <cstring>
#include <string>

#include "app/deck.hpp"
#include "app/run_options.hpp"
#include "io/input_error.hpp"
#include "app/simulation.hpp"
#include "app/study.hpp"

static const char usage[] =
    "usage: hyperqn DECK.yaml [-o OUTDIR] [PETSc options...]\n"
    "       hyperqn study DECK.yaml [-o OUTDIR] [PETSc options...]\n"
    "  Runs the scene described by DECK.yaml (see docs/decks.md), or with 'study' compares the\n"
    "  solvers of the deck's study: section (error against time, per frame and per trajectory).\n"
    "  -o OUTDIR   output directory (default: the deck's output.directory, else output/<deck name>;\n"
    "              for a study output/study/<deck name>)\n"
    "  PETSc options on the command line override the deck's petsc: section,\n"
    "  e.g. -tao_ls_type armijo -tao_lmvm_mat_lmvm_hist_size 10 -log_view\n";

namespace {

struct CommandLine {
  std::string deck, outdir;
  bool help = false, study = false;
};

// Our own arguments: the deck (first argument not starting with '-') and -o OUTDIR.
// Everything else belongs to PETSc.
CommandLine parse_command_line(int argc, char** argv) {
  CommandLine cl;
  int first = 1;
  if (argc > 1 && std::strcmp(argv[1], "study") == 0) {
    cl.study = true;
    first = 2;
  }
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help" || a == "-help") {
      cl.help = true;
    } else if (a == "-o") {
      if (i + 1 >= argc) throw hyperqn::InputError("", 0, "-o", "needs a directory");
      cl.outdir = argv[++i];
    } else if (a[0] != '-' && cl.deck.empty() && (i == first || argv[i - 1][0] != '-' || std::strcmp(argv[i - 1], "-o") == 0)) {
      cl.deck = a;
    }
  }
  if (!cl.help && cl.deck.empty()) throw hyperqn::InputError("", 0, "", "no deck given\n" + std::string(usage));
  return cl;
}

// The deck's petsc: options, unless the command line already set them.
PetscErrorCode insert_deck_options(const hyperqn::Deck& deck) {
  PetscFunctionBeginUser;
  for (const auto& [name, value] : deck.petsc_options) {
    PetscBool set;
    PetscCall(PetscOptionsHasName(nullptr, nullptr, name.c_str(), &set));
    if (!set) PetscCall(PetscOptionsSetValue(nullptr, name.c_str(), value.empty() ? nullptr : value.c_str()));
  }
  PetscFunctionReturn(0);
}

}  // namespace

int main(int argc, char** argv) {
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  int status = 0;
  try {
    const CommandLine cl = parse_command_line(argc, argv);
    if (cl.help) {
      // PETSc prints every option read in a PetscOptionsBegin block when -help is set.
      hyperqn::RunOptions options;
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s\n", usage));
      PetscCall(PetscOptionsSetValue(nullptr, "-help", nullptr));
      PetscCall(hyperqn::read_run_options(PETSC_COMM_WORLD, &options));
    } else {
      const hyperqn::Deck deck = hyperqn::load_deck(cl.deck);
      PetscCall(insert_deck_options(deck));
      std::string outdir = cl.outdir;
      if (cl.study) {
        if (outdir.empty()) outdir = "output/study/" + deck.name;
        status = hyperqn::run_study(PETSC_COMM_WORLD, deck, outdir);
      } else {
        if (outdir.empty()) outdir = deck.output.directory.empty() ? "output/" + deck.name : deck.output.directory;
        status = hyperqn::run_simulation(PETSC_COMM_WORLD, deck, outdir);
      }
    }
  } catch (const hyperqn::InputError& e) {
    PetscCall(PetscPrintf(PETSC_COMM_WORLD, "hyperqn: error: %s\n", e.what()));
    status = 1;
  }
  PetscCall(PetscFinalize());
  return status;
}
