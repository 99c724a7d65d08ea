// A scene deck: one YAML file describing one simulation: the scene (model/scene_spec.hpp) and
// how to run it (solver, output, study, extra PETSc options). The format is documented in docs/decks.md
// (and the pages it links: docs/deck-scene.md, docs/deck-run.md).
#pragma once
#include <array>
#include <map>
#include <string>
#include <vector>

#include "model/scene_spec.hpp"
#include "solvers/solver_spec.hpp"
#include "terms/element_fields.hpp"

namespace hyperqn {

// The error-against-time study (hyperqn study DECK): at each of `frames`, every solver in
// `solvers` starts from the same state; a converged Newton solve gives the reference g*.
struct StudySpec {
  std::vector<int> frames{1};
  std::vector<std::string> solvers;  // default (load_deck): every solver, solvers/solver_registry.hpp
  int iterations = 200;              // cap per solver and frame in the per-frame study
  double time_limit = 60;            // seconds per solver and frame
  double reference_rtol = 1e-10;     // reference Newton: ||grad g|| <= reference_rtol ||grad g(x0)||
  bool trajectory = true;            // also compare whole trajectories against converged Newton
  std::map<std::string, int> trajectory_iterations;  // per solver; default solver.iterations
  // The integrator axis: the study once per integrator, each into OUTDIR/<name>/ (empty: once,
  // with time.integrator, into OUTDIR).
  std::vector<TimeIntegrator> integrators;
};

enum class OutputFormat { vtu, xdmf };
inline const std::vector<std::string> kOutputFormatNames = {"vtu", "xdmf"};  // in the enum's order
enum class VtuEncoding { base64, raw };
inline const std::vector<std::string> kVtuEncodingNames = {"base64", "raw"};  // in the enum's order
// How output.fields' values are written (FrameElementField::single): as computed, or rounded to float.
enum class FieldPrecision { double_precision, single_precision };
inline const std::vector<std::string> kFieldPrecisionNames = {"double", "single"};  // in the enum's order

// The deck's study: keys (params/deck_keys.hpp; app/deck_keys.cpp, which knows the solvers).
const std::vector<DeckKey<StudySpec>>& study_keys();

// The deck's material: keys (app/deck_keys.cpp): model, then each key of the material registry
// (materials/material_factory.hpp: its range, the models that take it), then the mass and
// laplacian_weight. Its reader checks the rules that involve several keys.
const std::vector<DeckKey<MaterialSpec>>& material_keys();

struct OutputSpec {
  std::string directory;             // "" -> output/<deck name>
  int every = 1;                     // write VTK every N frames (frame 0 = initial state is always written)
  bool vtk = true;                   // write frames at all (in `format`)
  OutputFormat format = OutputFormat::vtu;  // vtu: VTK pieces per rank; xdmf: one HDF5 file per run (io/xdmf_writer.hpp)
  VtuEncoding vtu_encoding = VtuEncoding::base64;  // of the .vtu pieces' arrays (io/vtk_writer.hpp)
  bool iterations_csv = true;
  bool contact_csv = true;           // contact.csv (colliders), self-contact.csv (penalty self-contact)
  std::vector<std::string> fields;   // per-element fields of the frames (terms/element_fields.hpp); none by default
  std::vector<int> field_lines;      // the deck line of each of `fields` (read_output), for the scene's check
  FieldPrecision field_precision = FieldPrecision::double_precision;  // of `fields` in the files
  bool reactions = false;            // reactions.csv and summary.json's reactions (model/reactions.hpp)
  bool energy = false;               // energy.csv (model/energy_balance.hpp)
  bool topology_csv = true;          // topology.csv (cuts, fracture, snapping strands, tearing cloth; app/run_observers.hpp)
};

// The deck's output: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<OutputSpec>>& output_keys() {
  static const std::vector<DeckKey<OutputSpec>> keys = {
      {"directory", &OutputSpec::directory,
       "where results are written, a relative path (the default's too) from the directory hyperqn runs in, not "
       "the deck's (`-o DIR` overrides it); a run first removes the files an earlier run wrote there, and only those "
       "([outputs.md](outputs.md#a-directory-that-holds-an-earlier-run))",
       {}, {}, "", "`\"\"`, which means `output/<name>`"},
      {"every", &OutputSpec::every,
       "write frames every N frames. Frame 0 (the rest state) and the last frame are always written (also by a restart at its last frame, from a checkpoint of a run that went on past it).", at_least(1)},
      {"vtk", &OutputSpec::vtk, "write frames at all (in the `format` below; false: none)"},
      enum_key<OutputSpec>("format", &OutputSpec::format, kOutputFormatNames,
       "`vtu`: VTK files, one `.vtu` piece per rank and frame, a `.pvtu` and a `.pvd`; `xdmf`: one HDF5 file per run, "
       "`<name>.h5`, written by all ranks together, and its index `<name>.xdmf`, for runs on many ranks "
       "([outputs.md](outputs.md#xdmf-output-for-many-ranks))"),
      only_with(enum_key<OutputSpec>("vtu_encoding", &OutputSpec::vtu_encoding, kVtuEncodingNames,
       "how a `.vtu` piece holds its arrays: `base64` inline (what every reader reads), `raw` appended as they are, "
       "a quarter fewer bytes and no encoding (VTK, ParaView and meshio read it; a reader that strips whitespace "
       "around the appended block corrupts it; [outputs.md](outputs.md#element-fields))"),
       "format", {"vtu"}, false),
      {"iterations_csv", &OutputSpec::iterations_csv, "write the per-iteration solver log as CSV"},
      {"contact_csv", &OutputSpec::contact_csv,
       "with colliders: write `contact.csv` (per frame and collider); with penalty self-contact: write "
       "`self-contact.csv` (per frame, the surface triangle pairs that cross; [outputs.md](outputs.md))"},
      {"fields", &OutputSpec::fields,
       "per-element fields of the frames, each computed at output frames only, each once; the scene must have the "
       "elements a field is of, and frames to hold them (not with `vtk: false`) ([outputs.md](outputs.md#element-fields))",
       {}, element_field_names(), "", "none (leave the key out)"},
      enum_key<OutputSpec>("field_precision", &OutputSpec::field_precision, kFieldPrecisionNames,
       "how the values of `fields` are written: `double` as computed, `single` rounded to 32-bit floats (half the "
       "bytes, about 7 significant digits; the frames' positions and other arrays stay double; "
       "[outputs.md](outputs.md#element-fields))"),
      {"reactions", &OutputSpec::reactions,
       "write `reactions.csv`: per frame, the force and moment each fixed region and attachment exerts on the body, "
       "and their last and largest in `summary.json`; a scene with neither is warned of "
       "([outputs.md](outputs.md#reactionscsv))"},
      {"energy", &OutputSpec::energy,
       "write `energy.csv`: per frame, kinetic, stored and dissipated energy and what topology changes released, "
       "against the work of gravity, the loads and the supports, and the balance's residual "
       "([inelastic.md](inelastic.md#energy-balance)); not with "
       "colliders or self-contact"},
      {"topology_csv", &OutputSpec::topology_csv,
       "with cuts, fracture, snapping strands or tearing cloth: write `topology.csv` (per frame, the faces "
       "separated, vertices added, segments snapped, cloth edges torn, H0 corrections and refactorizations; [outputs.md](outputs.md#files))"},
  };
  return keys;
}

// The guardrails' limits (docs/guardrails.md): a run stops where one is passed, so they change
// results. The command line's -hyperqn_divergence_limit and -hyperqn_element_limit override them
// (RunOptions, app/run_options.hpp, starts from these values).
struct GuardrailSpec {
  // Divergence: an element edge (tet edge or strand segment) longer than this many rest
  // bounding-box diagonals D stops the run. At rest every edge is at most D long and rigid motions
  // (free fall, prescribed rotation or translation, pieces moving apart) keep edge lengths, so a
  // longer edge needs the body itself stretched about that much. Measured on the stability suite:
  // at most 0.91 D in the runs that stay bounded (random start), up to 1e9 D in those that run
  // away (docs/guardrails.md). <= 0: no check.
  double divergence_limit = 10.0;
  // Local blow-up: an element whose volume ratio |det F| exceeds this stops the run (a sliver can
  // grow a thousandfold and stay far below the divergence limit's edge length). No solid these
  // materials model changes its volume a hundredfold. <= 0: no check.
  double element_limit = 100.0;
};

// The deck's guardrails: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<GuardrailSpec>>& guardrail_keys() {
  static const std::vector<DeckKey<GuardrailSpec>> keys = {
      {"divergence_limit", &GuardrailSpec::divergence_limit,
       "the run stops when an element edge (tet edge or strand segment) is longer than this many rest bounding-box "
       "diagonals; ≤ 0: never. `-hyperqn_divergence_limit` on the command line overrides it "
       "([guardrails.md](guardrails.md))"},
      {"element_limit", &GuardrailSpec::element_limit,
       "the run stops when an element's \\|det F\\| exceeds this; ≤ 0: never. `-hyperqn_element_limit` on the command "
       "line overrides it ([guardrails.md](guardrails.md#element-blow-up-and-inversion))"},
  };
  return keys;
}

// When a run writes checkpoints (docs/deck-run.md#checkpoint): every `every` frames and/or when
// `seconds` of wall time passed since the last one (0: not by that rule); the newest `keep` remain.
struct CheckpointSpec {
  int every = 0;
  double seconds = 0;
  int keep = 2;
};

// The deck's checkpoint: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<CheckpointSpec>>& checkpoint_keys() {
  static const std::vector<DeckKey<CheckpointSpec>> keys = {
      {"every", &CheckpointSpec::every, "a checkpoint every N frames (at frames N, 2N, …)",
       at_least(0, "0: not by frame count"), {}, "", "0 (never by count)"},
      {"seconds", &CheckpointSpec::seconds,
       "a checkpoint after a frame when at least this much wall time passed since the last one (or the run's start)",
       at_least(0, "0: not by wall time"), {}, "s", "0 (never by time)"},
      {"keep", &CheckpointSpec::keep,
       "how many of the run's newest checkpoints remain in `OUTDIR/checkpoints/` (2 or more lets a restart fall back "
       "when the newest is damaged)",
       between(1, 1000)},
  };
  return keys;
}

// A key the deck gives: its line, its value as written (YAML flow style), and whether it is a
// leaf (not a map, nor a list of maps).
struct KeyPlace {
  int line = 0;
  std::string written;
  bool leaf = true;
};

struct Deck : SceneSpec {
  SolverSpec solver;
  OutputSpec output;
  CheckpointSpec checkpoint;
  GuardrailSpec guardrails;
  // (section, its YAML text) of the sections that define the physics (time without frames), in
  // a fixed order: a restart refuses a checkpoint whose sections' hashes differ.
  std::vector<std::pair<std::string, std::string>> physics;
  StudySpec study;
  std::vector<std::pair<std::string, std::string>> petsc_options;  // "-key", "value" (petsc: section)
  struct OptionPlace {
    int line = 0;
    std::string key;  // dotted, e.g. "petsc.tao.ls_type"
  };
  std::map<std::string, OptionPlace> petsc_option_places;  // "-key" -> where the deck gives it
  // Where the values came from (`hyperqn config`, app/deck_config.hpp): every key the deck gives
  // (dotted, e.g. "bodies[0].material.mu"), and the keys it leaves out that a rule set (-> the
  // rule, app/deck_rules.hpp).
  std::map<std::string, KeyPlace> key_places;
  std::map<std::string, std::string> rule_sources;
  // Every file the deck names (meshes, partition files, curve tables, obstacles' and blades'
  // surfaces), as resolved, with the line and key that name it: a run refuses one that it would
  // write or remove in its output directory.
  struct InputFile {
    std::string path;
    int line = 0;
    std::string key;
  };
  std::vector<InputFile> input_files;
};

// Bounds of the petsc: section (a YAML alias bomb expands past them).
constexpr int kMaxPetscOptions = 256;  // of PETSc 3.18's 512 in all (MAXOPTIONS), the command line's and its own among them
constexpr int kMaxPetscDepth = 8;

// The deck's petsc: keys (params/deck_keys.hpp): a free map, any option name, read by read_petsc.
inline const std::vector<DeckKey<Deck>>& petsc_keys() {
  static const std::string doc =
      "a PETSc option, named without its leading `-`: letters, digits and `_`, starting with a letter; a nested "
      "map's keys join its name with `_` (`tao: {ls_type: armijo}` is `-tao_ls_type armijo`), at most " +
      std::to_string(kMaxPetscDepth) + " levels deep; at most " + std::to_string(kMaxPetscOptions) +
      " options; each option once";
  static const std::vector<DeckKey<Deck>> keys = {
      any_key<Deck>("<option>", "a word, or a map of options", doc.c_str()),
  };
  return keys;
}

// Where the deck's petsc: section gave option `name` (e.g. "-tao_ls_type") the value `value`, or
// nullptr: the deck does not give it, or the command line set another value (the command line wins).
const Deck::OptionPlace* deck_option_place(const Deck& deck, const std::string& name, const std::string& value);

// Parses and validates a deck. Unknown keys, wrong types and impossible values throw
// InputError naming the file, line and dotted key.
Deck load_deck(const std::string& path);

}  // namespace hyperqn
