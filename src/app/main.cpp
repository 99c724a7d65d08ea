// hyperqn: implicit Euler for elastic solids as energy minimization, solved per time step by
// L-BFGS whose initial Hessian is the once-factored M + h^2 L (Liu, Bouaziz & Kavan 2017).
//
//   mpiexec -n N hyperqn DECK.yaml [-o OUTDIR] [--restart PATH|latest|auto] [PETSc options...]
//   mpiexec -n N hyperqn study DECK.yaml [-o OUTDIR] [PETSc options...]
//   hyperqn partition DECK.yaml -n N [-o FILE.h5]
//   hyperqn config DECK.yaml [-o OUTDIR] [PETSc options...]
#include <petscsys.h>

#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <cctype>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "app/deck.hpp"
#include "app/deck_config.hpp"
#include "app/run_options.hpp"
#include "mesh/input_error.hpp"
#include "app/partition_command.hpp"
#include "app/simulation.hpp"
#include "app/study.hpp"
#include "materials/material_factory.hpp"
#include "solvers/solver_registry.hpp"
#include "io/console.hpp"

static const char usage[] =
    "usage: hyperqn DECK.yaml [-o OUTDIR] [--restart PATH|latest|auto] [PETSc options...]\n"
    "       hyperqn study DECK.yaml [-o OUTDIR] [PETSc options...]\n"
    "       hyperqn partition DECK.yaml -n N [-o FILE.h5]\n"
    "       hyperqn config DECK.yaml [-o OUTDIR] [PETSc options...]\n"
    "       hyperqn registry   (the material models, solvers and declared deck keys, as JSON)\n"
    "       hyperqn --help-deck   (the deck keys declared with their types, ranges and defaults)\n"
    "  Runs the scene described by DECK.yaml (see docs/decks.md), or with 'study' compares the\n"
    "  solvers of the deck's study: section (error against time, per frame and per trajectory).\n"
    "  -o OUTDIR   output directory (default: the deck's output.directory, else output/<deck name>;\n"
    "              for a study output/study/<deck name>)\n"
    "  --restart PATH|latest|auto   continue the run that last wrote OUTDIR: from a checkpoint file of\n"
    "              it, or from its newest whole one in OUTDIR/checkpoints; auto: that, or the deck afresh\n"
    "              if it has none (docs/outputs.md#checkpoints); exit code 3: stopped by SIGTERM, SIGINT or\n"
    "              SIGUSR1 after writing a checkpoint\n"
    "  config: prints every setting of the run with its value and source (deck line, default, a rule, or\n"
    "              the command line); a run writes the same to OUTDIR/config.yaml (docs/deck-run.md)\n"
    "  partition: cuts the deck's mesh into N parts and writes them to FILE.h5, a partition file that a\n"
    "              deck names as mesh.file: a run then reads its part directly (docs/performance.md#partition-files);\n"
    "              a deck of bodies joins them, and names the file as partition: (then -o may be left out)\n"
    "  PETSc options on the command line override the deck's petsc: section,\n"
    "  e.g. -tao_ls_type armijo -tao_lmvm_mat_lmvm_hist_size 10 -log_view\n";

namespace {

struct CommandLine {
  std::string deck, outdir, restart;
  bool help = false, study = false, registry = false, partition = false, help_deck = false, config = false;
  int parts = 0;  // partition: -n
};

// hyperqn partition DECK -n N -o FILE.h5: every argument is ours (no PETSc options).
CommandLine parse_partition_command(int argc, char** argv) {
  CommandLine cl;
  cl.partition = true;
  const std::string form = "hyperqn partition DECK.yaml -n N -o FILE.h5";
  bool parts_given = false;
  for (int i = 2; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help" || a == "-help") {
      cl.help = true;
    } else if (a == "-n") {
      if (i + 1 >= argc) throw hyperqn::InputError("", 0, "-n", "needs the number of parts: " + form);
      if (parts_given) throw hyperqn::InputError("", 0, "-n", "given twice: " + form);
      const char* text = argv[++i];
      char* end = nullptr;
      errno = 0;
      const long n = std::strtol(text, &end, 10);
      if (end == text || *end != '\0' || errno == ERANGE || n < 1 || n > 1000000)
        throw hyperqn::InputError("", 0, "-n", "must be a whole number of parts from 1 to 1000000, got '" + std::string(text) + "'");
      cl.parts = int(n);
      parts_given = true;
    } else if (a == "-o") {
      if (i + 1 >= argc) throw hyperqn::InputError("", 0, "-o", "needs the partition file to write: " + form);
      if (!cl.outdir.empty()) throw hyperqn::InputError("", 0, "-o", "given twice: " + form);
      cl.outdir = argv[++i];
    } else if (a[0] != '-' && cl.deck.empty()) {
      cl.deck = a;
    } else {
      throw hyperqn::InputError("", 0, a, "unexpected argument: " + form);
    }
  }
  if (cl.help) return cl;
  if (cl.deck.empty()) throw hyperqn::InputError("", 0, "", "no deck given: " + form);
  if (!parts_given) throw hyperqn::InputError("", 0, "-n", "missing: the number of parts: " + form);
  // Without -o: the deck's partition: (run_partition).
  const std::string& out = cl.outdir;
  if (!out.empty() && (out.size() < 4 || out.compare(out.size() - 3, 3, ".h5") != 0 || out.back() == '/'))
    throw hyperqn::InputError("", 0, "-o", "'" + out + "': a partition file's name ends in .h5");
  return cl;
}

// Our own arguments: the deck (first argument not starting with '-') and -o OUTDIR.
// Everything else belongs to PETSc.
CommandLine parse_command_line(int argc, char** argv) {
  CommandLine cl;
  int first = 1;
  if (argc > 1 && std::strcmp(argv[1], "study") == 0) {
    cl.study = true;
    first = 2;
  }
  if (argc > 1 && std::strcmp(argv[1], "config") == 0) {
    cl.config = true;
    first = 2;
  }
  if (argc > 1 && std::strcmp(argv[1], "partition") == 0) return parse_partition_command(argc, argv);
  if (argc > 1 && (std::strcmp(argv[1], "registry") == 0 || std::strcmp(argv[1], "--help-deck") == 0)) {
    if (argc > 2) throw hyperqn::InputError("", 0, argv[1], "takes no argument, got '" + std::string(argv[2]) + "'");
    (std::strcmp(argv[1], "registry") == 0 ? cl.registry : cl.help_deck) = true;
    return cl;
  }
  std::pair<std::string, std::string> taken_deck;  // a PETSc option and the deck-like word it takes as its value
  for (int i = first; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "-h" || a == "--help" || a == "-help") {
      cl.help = true;
    } else if (a == "--help-deck") {
      cl.help_deck = true;
    } else if (a == "-o") {
      if (i + 1 >= argc || !*argv[i + 1]) throw hyperqn::InputError("", 0, "-o", "needs a directory");
      if (argv[i + 1][0] == '-')  // another option: the run would write into a directory of that name
        throw hyperqn::InputError("", 0, "-o", "needs a directory, got the option '" + std::string(argv[i + 1]) +
                                               "' (a directory whose name starts with - is written ./-name)");
      if (!cl.outdir.empty()) throw hyperqn::InputError("", 0, "-o", "given twice (" + cl.outdir + ", " + argv[i + 1] + ")");
      cl.outdir = argv[++i];
    } else if (a == "--restart") {
      // An empty value would start afresh, removing the run it was meant to continue.
      if (i + 1 >= argc || !*argv[i + 1] || argv[i + 1][0] == '-')
        throw hyperqn::InputError("", 0, "--restart", "needs a checkpoint file, 'latest' or 'auto'");
      if (!cl.restart.empty())
        throw hyperqn::InputError("", 0, "--restart", "given twice (" + cl.restart + ", " + argv[i + 1] + ")");
      cl.restart = argv[++i];
    } else if (a == "-restart" || a.rfind("--restart=", 0) == 0 || a.rfind("-o=", 0) == 0) {
      // PETSc would take these as options nothing reads: the run would start afresh.
      const std::string ours = a.rfind("-o", 0) == 0 ? "-o" : "--restart";
      throw hyperqn::InputError("", 0, a, "not an option: write " + ours + " VALUE (" + ours + ", a space, its value)");
    } else if (a == "-" || a == "--") {
      throw hyperqn::InputError("", 0, a, "not an option (hyperqn reads no standard input and has no '--')");
    } else if (a.size() > 2 && a[0] == '-' && a[1] == '-') {
      throw hyperqn::InputError("", 0, a, "not an option of hyperqn (its long options are --restart, --help, --help-deck; "
                                          "PETSc's start with one -)");
    } else if (a.empty() || a[0] != '-') {
      // The deck, or the value of the PETSc option before it; any other word would be dropped unsaid.
      if (i > first && argv[i - 1][0] == '-' && argv[i - 1][1] != '\0') {
        if (a.size() > 5 && (a.compare(a.size() - 5, 5, ".yaml") == 0 || a.compare(a.size() - 4, 4, ".yml") == 0))
          taken_deck = {argv[i - 1], a};
        continue;
      }
      if (!cl.deck.empty())
        throw hyperqn::InputError("", 0, "", "unexpected argument '" + a + "': the deck is " + cl.deck +
                                                 " (one deck a run; options start with -)\n" + std::string(usage));
      cl.deck = a;
    }
  }
  if (cl.config && !cl.restart.empty()) throw hyperqn::InputError("", 0, "--restart", "continues a run; config only reads the deck");
  if (cl.study && !cl.restart.empty()) throw hyperqn::InputError("", 0, "--restart", "continues a run, not a study");
  if (!cl.help && !cl.help_deck && cl.deck.empty() && !taken_deck.first.empty())
    throw hyperqn::InputError("", 0, "", "no deck given: PETSc takes " + taken_deck.second + " as the value of " +
                                             taken_deck.first + "; give the deck first (hyperqn " + taken_deck.second +
                                             " " + taken_deck.first + " ...)");
  if (!cl.help && !cl.help_deck && cl.deck.empty()) throw hyperqn::InputError("", 0, "", "no deck given\n" + std::string(usage));
  return cl;
}

// The material models and the solvers, from their registries: for --help (text) and for the
// Python tools (`hyperqn registry`, JSON).
std::string quoted(const std::string& s) {
  std::string q = "\"";
  for (char c : s) q += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
  return q + "\"";
}

std::string registry_text() {
  std::string s = "Material models (material.model):\n";
  for (const hyperqn::MaterialModel& m : hyperqn::material_models())
    s += "  " + m.name + ": " + m.summary + "\n      keys: " + hyperqn::parameters_text(m) + "\n";
  s += "Solvers (solver.type):\n";
  for (const hyperqn::SolverInfo& v : hyperqn::solver_registry()) s += "  " + v.name + ": " + v.summary + "\n";
  return s;
}

std::string registry_json() {
  std::string s = "{\n  \"materials\": [\n";
  const auto& models = hyperqn::material_models();
  for (size_t k = 0; k < models.size(); ++k)
    s += "    {\"name\": " + quoted(models[k].name) + ", \"summary\": " + quoted(models[k].summary) +
         ", \"parameters\": " + quoted(hyperqn::parameters_text(models[k])) + "}" + (k + 1 < models.size() ? ",\n" : "\n");
  s += "  ],\n  \"solvers\": [\n";
  const auto& solvers = hyperqn::solver_registry();
  for (size_t k = 0; k < solvers.size(); ++k)
    s += "    {\"name\": " + quoted(solvers[k].name) + ", \"summary\": " + quoted(solvers[k].summary) +
         ", \"uses_constant_matrix\": " + (solvers[k].uses_constant_matrix ? "true" : "false") + "}" +
         (k + 1 < solvers.size() ? ",\n" : "\n");
  s += "  ],\n  \"deck_keys\": [\n";
  const std::vector<hyperqn::KeyInfo> keys = hyperqn::declared_deck_keys();
  for (size_t k = 0; k < keys.size(); ++k) {
    std::string choices;
    for (const std::string& c : keys[k].choices) choices += (choices.empty() ? "" : ", ") + quoted(c);
    s += "    {\"section\": " + quoted(keys[k].section) + ", \"name\": " + quoted(keys[k].name) +
         ", \"type\": " + quoted(keys[k].type) + ", \"default\": " + quoted(keys[k].default_value) +
         ", \"unit\": " + quoted(keys[k].unit) + ", \"choices\": [" + choices + "], \"doc\": " + quoted(keys[k].doc) +
         "}" + (k + 1 < keys.size() ? ",\n" : "\n");
  }
  return s + "  ]\n}\n";
}

// hyperqn --help-deck: the declared deck keys, section by section.
std::string deck_keys_text() {
  std::string s = "Deck keys declared with their types, ranges and defaults (docs/decks.md lists every section and the page of its table):\n";
  std::string section;
  for (const hyperqn::KeyInfo& k : hyperqn::declared_deck_keys()) {
    if (k.section != section) s += "\n" + (section = k.section) + ":\n";
    std::string type = k.type;
    if (!k.choices.empty()) {
      type = k.type == "list" ? "list of " : "";
      for (size_t i = 0; i < k.choices.size(); ++i) type += (i ? " | " : "") + k.choices[i];
    }
    const std::string given = k.default_value.rfind("required", 0) == 0 ? k.default_value : "default " + k.default_value;
    s += "  " + k.name + ": " + type + " (" + given + (k.unit.empty() ? "" : ", in " + k.unit) +
         ")\n      " + k.doc + "\n";
  }
  return s;
}

// Options given (command line or the deck's petsc: section) that nothing read: most often a
// misspelling, or an option of another solver. Said, not fatal: the run is done by now.
PetscErrorCode warn_unused_options() {
  PetscInt n;
  char **names, **values;
  PetscFunctionBeginUser;
  PetscCall(PetscOptionsLeftGet(nullptr, &n, &names, &values));
  for (PetscInt i = 0; i < n; ++i)
    if (std::strcmp(names[i], "o") != 0 && std::strcmp(names[i], "-restart") != 0)  // -o, --restart are ours
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "hyperqn: warning: option -%s was given but never used (misspelt, or not "
                                              "an option of this solver?)\n", names[i]));
  PetscCall(PetscOptionsLeftRestore(nullptr, &n, &names, &values));
  PetscFunctionReturn(0);
}

// The most options PETSc 3.18 holds is 512 (MAXOPTIONS; past them its stack trace, exit 55); 64 are
// left for those hyperqn and PETSc set as the run goes (insert_deck_options counts the deck's too).
constexpr size_t kMaxGivenOptions = 448;

// The deck's petsc: options, unless the command line already set them.
PetscErrorCode insert_deck_options(const hyperqn::Deck& deck) {
  PetscFunctionBeginUser;
  const size_t given = hyperqn::all_options().size();
  if (given + deck.petsc_options.size() > kMaxGivenOptions)
    throw hyperqn::InputError(deck.path, 0, "petsc", "the command line (" + std::to_string(given) + " options) and this "
                              "section (" + std::to_string(deck.petsc_options.size()) + ") give more than 448 PETSc options");
  for (const auto& [name, value] : deck.petsc_options) {
    PetscBool set;
    PetscCall(PetscOptionsHasName(nullptr, nullptr, name.c_str(), &set));
    if (!set) PetscCall(PetscOptionsSetValue(nullptr, name.c_str(), value.empty() ? nullptr : value.c_str()));
  }
  PetscFunctionReturn(0);
}

// The options PETSc reads as it starts, as (name, value) pairs in its order: the command line,
// PETSC_OPTIONS, and every options file these name (nested ones too; '#' starts a comment). A
// file that cannot be opened is a problem of its own: PETSc would stop on it with its stack trace
// (and open it on rank 0 alone, the other ranks left waiting).
struct OptionWord {
  std::string name, value;
  std::string where;  // "" on the command line, else " (in PETSC_OPTIONS)" or " (named in FILE)"
};
using OptionWords = std::vector<OptionWord>;

void add_option_words(const std::vector<std::string>& words, const std::string& where, int depth, OptionWords& out,
                      std::string& problem);

// text split at whitespace, as PETSc splits options.
std::vector<std::string> words_of(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

void add_options_file(const std::string& name, const std::string& path, const std::string& where, int depth,
                      OptionWords& out, std::string& problem) {
  std::ifstream file(path);
  if (!file) {
    problem = "option " + name + " " + path + where + ": cannot open the file";
    return;
  }
  if (name != "-options_file" || depth > 10) return;  // YAML files are PETSc's to read; a loop of files stops
  std::vector<std::string> words;
  for (std::string line; std::getline(file, line);)
    for (const std::string& w : words_of(line.substr(0, line.find('#')))) words.push_back(w);
  add_option_words(words, " (named in " + path + ")", depth + 1, out, problem);
}

void add_option_words(const std::vector<std::string>& words, const std::string& where, int depth, OptionWords& out,
                      std::string& problem) {
  for (size_t i = 0; i < words.size() && problem.empty(); ++i) {
    const std::string& name = words[i];
    if (name.size() < 2 || name[0] != '-') continue;
    const std::string value = i + 1 < words.size() ? words[i + 1] : "";
    out.push_back({name, value, where});
    if ((name == "-options_file" || name == "-options_file_yaml") && !value.empty())
      add_options_file(name, value, where, depth, out, problem);
  }
}

// hyperqn's own words -o and --restart, and their misspellings (-o=DIR, -restart, --restart=latest):
// read from the command line alone. From an options file or PETSC_OPTIONS nothing would read them:
// the run would start afresh, removing the run --restart names, or write elsewhere than -o says.
bool run_word(const std::string& name) {
  return name == "-o" || name == "--restart" || name == "-restart" || name.rfind("-o=", 0) == 0 ||
         name.rfind("--restart=", 0) == 0 || name.rfind("-restart=", 0) == 0;
}

std::string run_word_problem(const std::string& name, const std::string& value, const std::string& where) {
  const bool takes_value = name == "-o" || name == "--restart" || name == "-restart";
  return "option " + name + (takes_value && !value.empty() ? " " + value : "") + where + ": " +
         (name.rfind("-o", 0) == 0 ? "-o OUTDIR" : "--restart VALUE") + " is read from the command line only (from "
         "an options file or PETSC_OPTIONS the run would ignore it: start afresh and remove the run it names, or "
         "write into another directory); give it on the command line";
}

// What PETSc reads as it starts and would fail on with its stack trace: options files that cannot
// be opened, more options than it holds, and -log_view's format (hyperqn::log_view_problem); and
// hyperqn's own words where only the command line is read (run_word). "" if none.
std::string start_option_problem(int argc, char** argv) {
  std::string problem;
  OptionWords options;
  add_option_words(std::vector<std::string>(argv + 1, argv + argc), "", 0, options, problem);
  if (const char* env = std::getenv("PETSC_OPTIONS"); env && problem.empty())
    add_option_words(words_of(env), " (in PETSC_OPTIONS)", 0, options, problem);
  if (!problem.empty()) return problem;
  for (const OptionWord& o : options)
    if (!o.where.empty() && run_word(o.name)) return run_word_problem(o.name, o.value, o.where);
  // Counted as PETSc holds them: each name once (a name given again replaces its value; names are
  // not case-sensitive). A value that looks like an option (-x -1) is counted too: at most over.
  std::set<std::string> names;
  for (const OptionWord& o : options) {
    if (o.name == "-options_file" || o.name == "-options_file_yaml") continue;  // read, not held
    std::string lower = o.name;
    for (char& c : lower) c = static_cast<char>(std::tolower((unsigned char)c));
    names.insert(lower);
  }
  if (names.size() > kMaxGivenOptions)
    return "more than " + std::to_string(kMaxGivenOptions) + " PETSc options (" + std::to_string(names.size()) +
           " names on the command line, in PETSC_OPTIONS and in the options files they name; PETSc holds 512, and "
           "hyperqn and PETSc set some as the run goes)";
  for (const OptionWord& o : options)
    if (o.name == "-log_view" && !o.value.empty() && o.value[0] != '-')
      if (const std::string why = hyperqn::log_view_problem(o.value); !why.empty())
        return "option -log_view " + o.value + ": " + why;
  return "";
}

// After PetscInitialize: -o or --restart in the options database that the command line did not
// give came from where start_option_problem does not look (a YAML options file, a .petscrc).
std::string run_words_not_on_the_command_line(const CommandLine& cl) {
  for (const auto& [name, value] : hyperqn::all_options()) {
    if (!run_word(name)) continue;
    if ((name == "-o" && !cl.outdir.empty()) || (name == "--restart" && !cl.restart.empty())) continue;
    return run_word_problem(name, value, " (not on the command line: from a YAML options file or a .petscrc)");
  }
  return "";
}

// Said once, before PETSc starts; every rank reads the same command line and refuses it alike.
int refuse_start(const std::string& problem) {
  int rank = 0;
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  if (rank == 0) std::fprintf(stderr, "hyperqn: error: command line: %s\n", problem.c_str());
  MPI_Finalize();
  return 1;
}

}  // namespace

int main(int argc, char** argv) {
  // A simulation turns stop signals into a checkpoint from the start, a study into its files of the
  // frames it finished (not the registry, partition or config).
  if (argc > 1 && std::strcmp(argv[1], "registry") != 0 &&
      std::strcmp(argv[1], "partition") != 0 && std::strcmp(argv[1], "config") != 0)
    hyperqn::catch_stop_signals();
  if (const std::string problem = start_option_problem(argc, argv); !problem.empty()) {
    MPI_Init(&argc, &argv);
    return refuse_start(problem);
  }
  PetscCall(PetscInitialize(&argc, &argv, nullptr, nullptr));
  // A closed pipe (`hyperqn registry | head`) ends the program quietly, as it does any other
  // command's, instead of PETSc's handler reporting a crash and aborting MPI.
  std::signal(SIGPIPE, SIG_DFL);
  int status = 0;
  try {
    const CommandLine cl = parse_command_line(argc, argv);
    if (const std::string problem = run_words_not_on_the_command_line(cl); !problem.empty() &&
        !cl.partition && !cl.registry && !cl.help_deck && !cl.help)
      throw hyperqn::InputError("", 0, "", problem);
    if (cl.registry) {
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s", registry_json().c_str()));
    } else if (cl.help_deck) {
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s", deck_keys_text().c_str()));
    } else if (cl.help) {
      // PETSc prints every option read in a PetscOptionsBegin block when -help is set.
      hyperqn::RunOptions options;
      PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s\n%s\n", usage, registry_text().c_str()));
      PetscCall(PetscOptionsSetValue(nullptr, "-help", nullptr));
      PetscCall(hyperqn::read_run_options(PETSC_COMM_WORLD, &options));
    } else if (cl.partition) {
      hyperqn::run_partition(PETSC_COMM_WORLD, hyperqn::load_deck(cl.deck), cl.parts, cl.outdir);
    } else {
      const hyperqn::Deck deck = hyperqn::load_deck(cl.deck);
      PetscCall(insert_deck_options(deck));
      std::string outdir = cl.outdir;
      if (cl.config) {
        if (outdir.empty()) outdir = deck.output.directory.empty() ? "output/" + deck.name : deck.output.directory;
        hyperqn::RunOptions options;
        PetscCall(hyperqn::read_run_options(PETSC_COMM_WORLD, &options, &deck));
        PetscCall(PetscPrintf(PETSC_COMM_WORLD, "%s", hyperqn::effective_config(deck, options, outdir).c_str()));
      } else if (cl.study) {
        if (outdir.empty()) outdir = "output/study/" + deck.name;
        status = hyperqn::run_study(PETSC_COMM_WORLD, deck, outdir);
      } else {
        if (outdir.empty()) outdir = deck.output.directory.empty() ? "output/" + deck.name : deck.output.directory;
        status = hyperqn::run_simulation(PETSC_COMM_WORLD, deck, outdir, cl.restart);
      }
      if (!cl.config && (status == 0 || status == hyperqn::kExitInverted || status == hyperqn::kExitInterrupted)) PetscCall(warn_unused_options());  // after a failure they may just not be reached
    }
  } catch (const hyperqn::InputError& e) {  // thrown on every rank alike
    PetscCall(hyperqn::print_error(PETSC_COMM_WORLD, e.what()));
    PetscCall(PetscOptionsClearValue(nullptr, "-log_view"));  // nothing ran: no log to write, or to fail on
    status = 1;
  } catch (const std::exception& e) {  // maybe on one rank only: the others must not wait for it
    std::fprintf(stderr, "hyperqn: error: %s\n", e.what());
    MPI_Abort(PETSC_COMM_WORLD, 1);
  }
  PetscCall(PetscFinalize());
  return status;
}
