// A deck's top level: the file, its one YAML document, which sections it has and in what order
// they are read (each by its reader, app/deck_sections.cpp), and the rules between them
// (app/deck_rules.cpp). The generic reading of keys is app/deck_reader.hpp. Every problem becomes
// an InputError naming the deck file, the line and the dotted key, so a user can fix a deck
// without reading this code.
#include "app/deck.hpp"

#include <yaml-cpp/yaml.h>

#include <cstdint>
#include <cstdio>
#include <algorithm>
#include <fstream>
#include <iterator>
#include <set>
#include <vector>

#include "app/deck_reader.hpp"
#include "app/deck_rules.hpp"
#include "app/deck_sections.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn {
namespace {

using namespace deck_reading;

// Bounds that keep a deck from exhausting the machine.
// Parsing takes some 250 bytes of memory per byte of the deck, on every rank (yaml-cpp's nodes):
// 10 MB took 2.6 GB a rank. A curve's long table goes in a file of its own.
constexpr std::uintmax_t kMaxDeckBytes = 1 << 20;
constexpr size_t kMaxNameLength = 100;

// The sections that define the physics as YAML text (time without frames, which only says how
// long to run): what a checkpoint's physics hash is made of. A section the deck leaves out is "".
// Not `mesh`: the mesh is recognised by the hash of the mesh as built (piece_hash_sums), so a run
// started from a mesh file may continue from its partition file, and a changed mesh is still refused.
std::vector<std::pair<std::string, std::string>> physics_sections(const YAML::Node& root) {
  std::vector<std::pair<std::string, std::string>> out;
  for (const char* key : {"material", "strand_material", "regions", "fixed", "attachments", "colliders",
                          "contact", "initial", "gravity", "time", "cloth", "bodies", "loads", "cuts"}) {
    const YAML::Node found = root.IsMap() ? root[key] : YAML::Node();
    if (!found || found.IsNull()) {
      if (std::string(key) == "cloth" || std::string(key) == "bodies" || std::string(key) == "loads" || std::string(key) == "cuts")
        continue;  // added later: decks without one keep their hash
      out.emplace_back(key, "");
      continue;
    }
    YAML::Node node = YAML::Clone(found);
    if (std::string(key) == "time" && node.IsMap()) node.remove("frames");
    out.emplace_back(key, YAML::Dump(node));
  }
  return out;
}

// The tables of the curves read from files (params/curve.hpp, a table's `file`), as their values:
// physics that the deck's text does not hold, so that a restart with a changed file is refused. ""
// without one (those decks keep their hash).
std::string curve_file_tables(const Deck& deck) {
  std::string text;
  const auto add = [&](const std::string& key, const Curve& c) {
    if (c.file.empty()) return;
    text += key + "\n";
    char row[64];
    for (const auto& p : c.points) {
      std::snprintf(row, sizeof row, "%.17g, %.17g\n", p[0], p[1]);
      text += row;
    }
  };
  for (size_t k = 0; k < deck.fixed.size(); ++k) add("fixed " + std::to_string(k), deck.fixed[k].motion.curve);
  for (size_t k = 0; k < deck.attachments.size(); ++k)
    add("attachments " + std::to_string(k), deck.attachments[k].region.motion.curve);
  for (size_t k = 0; k < deck.colliders.size(); ++k) add("colliders " + std::to_string(k), deck.colliders[k].motion.curve);
  for (size_t k = 0; k < deck.loads.size(); ++k) add("loads " + std::to_string(k), deck.loads[k].curve);
  for (size_t k = 0; k < deck.cuts.size(); ++k) add("cuts " + std::to_string(k), deck.cuts[k].motion.curve);
  return text;
}

// The contents of the other files the physics reads beside the mesh's elements: a blade's
// surface, a collider's mesh, and the mesh file when a load selects its tagged faces (the mesh's
// hash covers its elements, not its faces). A restart with one changed is refused. "" without one.
std::string physics_file_contents(const Deck& deck) {
  std::string text;
  const auto add = [&](const std::string& key, const std::string& file) {
    if (file.empty()) return;
    std::ifstream in(file, std::ios::binary);
    // The contents alone: the same deck named by another path (absolute, or from another directory)
    // resolves the file to another path, and must still restart.
    text += key + "\n" + std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()) + "\n";
  };
  for (size_t k = 0; k < deck.cuts.size(); ++k) add("cuts " + std::to_string(k), deck.cuts[k].surface);
  for (size_t k = 0; k < deck.colliders.size(); ++k)
    if (deck.colliders[k].type == ColliderType::mesh) add("colliders " + std::to_string(k), deck.colliders[k].file);
  if (std::any_of(deck.loads.begin(), deck.loads.end(), [](const LoadSpec& l) { return l.has_face_tag; })) {
    add("mesh", deck.mesh.file);
    for (size_t k = 0; k < deck.bodies.size(); ++k) add("bodies " + std::to_string(k), deck.bodies[k].mesh.file);
  }
  return text;
}

Deck parse(const Reader& r, const YAML::Node& root, const std::string& path) {
  Deck deck;
  deck.path = path;
  deck.study.solvers = solver_names();
  deck.name = fs::path(path).stem().string();

  Section s(r, Value{root, "", line_of(root)},
            {"name", "mesh", "bodies", "partition", "material", "strand_material", "cloth", "regions", "fixed", "attachments",
             "loads", "cuts", "colliders", "contact", "initial", "gravity", "time", "solver", "guardrails", "output", "checkpoint", "study", "petsc"});
  // The name becomes a directory and file names (output/<name>/<name>_00001.vtu).
  const auto safe_name = [](const std::string& name) {
    return !name.empty() && name.size() <= kMaxNameLength && name[0] != '.' && name[0] != '-' &&
           std::all_of(name.begin(), name.end(), [](char c) {
             return std::isalnum((unsigned char)c) || c == '_' || c == '-' || c == '.' || c == '+';
           });
  };
  const char* rule = "a file name of at most 100 letters, digits and _ - . + (not starting with . or -)";
  if (const Value* x = s.find("name")) {
    deck.name = r.text(*x);
    if (deck.name.empty() || deck.name.find_first_of("/\\") != std::string::npos)
      r.fail(*x, "must be a non-empty name without '/' or '\\'");
    if (!safe_name(deck.name)) r.fail(*x, std::string("must be ") + rule);
  } else if (!safe_name(deck.name)) {  // the default, the deck file's name
    r.fail(line_of(root), "name", "left out, is the deck file's name '" + deck.name + "', which is not " + rule +
                                      ": give name, or rename the file");
  }
  BodyRegions body_regions;  // read after the scene's own fixed regions and attachments
  if (const Value* x = s.find("bodies")) {
    for (const char* key : {"mesh", "material", "regions", "strand_material", "cloth"})
      if (const Value* y = s.find(key))
        r.fail(*y, std::string("with bodies, each body has its own mesh and material: ") + key +
                       " is a key of bodies[k] (or leave out bodies for a scene of one body)");
    read_bodies(r, *x, fs::path(path).parent_path(), deck, body_regions);
    if (const Value* y = s.find("partition")) read_bodies_partition(r, *y, fs::path(path).parent_path(), deck);
  } else {
    if (const Value* y = s.find("partition"))
      r.fail(*y, "names the partition file of a scene of bodies (bodies:); a deck of one mesh names its partition file "
                 "as mesh.file");
    const Value& mesh = s.need("mesh");
    read_mesh(r, mesh, fs::path(path).parent_path(), deck.mesh);
    // material (and regions) describe the tets, strand_material the strand segments: each is
    // required exactly when the mesh has that kind of element. Whether a Medit file read for its
    // edges also has tets is only known once it is read (load_scene_mesh checks).
    const bool may_be_strands_only = deck.mesh.edges_as_strands;
    if (const Value* x = s.find("material"); x && deck.mesh.has_solid()) {
      read_material(r, *x, deck.material);
      deck.has_material = true;
    } else if (deck.mesh.has_solid() && !may_be_strands_only) {
      s.need("material");
    } else if (!deck.mesh.has_solid() && !deck.mesh.has_cloth()) {
      for (const char* key : {"material", "regions"})
        if (const Value* x = s.find(key))
          r.fail(*x, "the mesh is strands only (no file or box): " + std::string(key) +
                         " describes tets; the strands take strand_material");
    }
    if (deck.mesh.has_strands()) {
      if (!s.find("strand_material"))
        r.fail(mesh.line, "strand_material", "missing required key 'strand_material': the mesh has strands");
      read_strand_material(r, *s.find("strand_material"), deck.strand_material);
    } else if (const Value* x = s.find("strand_material")) {
      r.fail(*x, "the mesh has no strands (give mesh.strands, or mesh.edges: strands with a Medit file)");
    }
    if (deck.mesh.has_cloth()) {
      if (!s.find("cloth")) r.fail(mesh.line, "cloth", "missing required key 'cloth': the mesh is a cloth surface");
      read_cloth(r, *s.find("cloth"), deck.cloth);
      for (const char* key : {"material", "regions"})
        if (const Value* x = s.find(key))
          r.fail(*x, "the mesh is a cloth surface: " + std::string(key) + " describes tets; the cloth takes cloth");
    } else if (const Value* x = s.find("cloth")) {
      r.fail(*x, "the mesh is not a cloth (give mesh.sheet, an .obj file, or mesh.surface: cloth with a .mesh or .msh file)");
    }
  }
  if (const Value* x = s.find("regions")) read_regions(r, *x, deck.material, deck.regions);
  if (const Value* x = s.find("initial")) read_initial(r, *x, deck.initial);
  if (const Value* x = s.find("fixed")) read_fixed(r, *x, deck.fixed);
  if (const Value* x = s.find("colliders")) read_colliders(r, *x, fs::path(path).parent_path(), deck.colliders);
  if (const Value* x = s.find("contact")) {
    const Section keys(r, *x, {});  // (kept: find points into it)
    const Value* self = keys.find("self");
    check_contact_has_surfaces(r, *x, deck);
    read_contact(r, *x, deck.contact);
    if (self) deck.contact.self_line = self->line;
  }
  check_thickness_in_self_contact(r, deck);
  if (const Value* x = s.find("attachments")) read_attachments(r, *x, deck.attachments);
  read_body_regions(r, body_regions, deck);
  if (const Value* x = s.find("loads")) read_loads(r, *x, deck.loads);
  if (const Value* x = s.find("cuts")) {
    read_cuts(r, *x, deck.cuts);
    deck.cuts_line = x->line;
  }
  check_face_tags_have_a_file(r, deck);
  if (const Value* x = s.find("gravity")) read_value(r, gravity_keys()[0], *x, static_cast<SceneSpec&>(deck));
  if (const Value* x = s.find("time")) {
    read_time(r, *x, deck.time);
    check_integrator_takes_contact(r, *x, deck);
    check_static_has_support(r, *x, deck);
  }
  if (const Value* x = s.find("solver")) read_solver(r, *x, deck.solver);
  apply_contact_solver_defaults(r, s.find("solver"), deck);
  apply_roller_solver_rules(r, s.find("solver"), deck);
  if (const Value* x = s.find("guardrails")) read_guardrails(r, *x, deck.guardrails);
  if (const Value* x = s.find("output")) {
    read_output(r, *x, deck.output);
    check_energy_output(r, *x, deck);
    check_fields_have_frames(r, *x, deck);
  }
  if (const Value* x = s.find("checkpoint")) read_checkpoint(r, *x, deck.checkpoint);
  if (const Value* x = s.find("cuts")) check_cuts(r, *x, deck);
  check_fracture(r, deck);
  deck.physics = physics_sections(root);
  if (const std::string tables = curve_file_tables(deck); !tables.empty()) deck.physics.emplace_back("curve_tables", tables);
  if (const std::string files = physics_file_contents(deck); !files.empty()) deck.physics.emplace_back("files", files);
  if (const Value* x = s.find("study")) {
    read_study(r, *x, deck.time.frames, deck.study);
    check_study_integrators_take_contact(r, *x, deck);
  }
  if (const Value* x = s.find("petsc")) read_petsc(r, *x, "", deck);
  return deck;
}

}  // namespace

const Deck::OptionPlace* deck_option_place(const Deck& deck, const std::string& name, const std::string& value) {
  const auto place = deck.petsc_option_places.find(name);
  if (place == deck.petsc_option_places.end()) return nullptr;
  for (const auto& [n, v] : deck.petsc_options)
    if (n == name) return v == value ? &place->second : nullptr;
  return nullptr;
}

// A YAML alias inside the node it names (`gravity: &g [0, *g, 0]`) makes that node its own
// descendant: every walk over it would recurse without end (a stack overflow). Refused, naming
// the anchored node's line; a node reached again by another alias is walked once (`done`, by its
// place in the file), so that an alias bomb's repetitions cost nothing here.
static void check_no_cycle(const Reader& r, const YAML::Node& node, std::vector<YAML::Node>& path, std::set<size_t>& done) {
  if (!node.IsMap() && !node.IsSequence()) return;
  const YAML::Mark mark = node.Mark();
  if (mark.pos >= 0 && done.count(size_t(mark.pos))) return;
  for (const YAML::Node& above : path)
    if (above.is(node))
      r.fail(mark.line + 1, "", "a YAML alias refers to the node it is in (a node that contains itself)");
  path.push_back(node);
  if (node.IsMap())
    for (const auto& item : node) {
      check_no_cycle(r, item.first, path, done);
      check_no_cycle(r, item.second, path, done);
    }
  else
    for (const YAML::Node& item : node) check_no_cycle(r, item, path, done);
  path.pop_back();
  if (mark.pos >= 0) done.insert(size_t(mark.pos));
}

Deck load_deck(const std::string& path) {
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(path, 0, "", "deck file not found");
  if (fs::is_directory(path, ec)) throw InputError(path, 0, "", "is a directory, not a deck file");
  // A pipe or a device (/dev/stdin, a FIFO, whose opening waits for a writer) has no size to check.
  if (!fs::is_regular_file(path, ec))
    throw InputError(path, 0, "", "not a regular file: a deck is a file (its size is checked before it is read)");
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "", "cannot read the deck file");
  if (fs::file_size(path, ec) > kMaxDeckBytes) throw InputError(path, 0, "", "larger than 1 MB: not a deck (parsing takes some 250 times its size in memory on every "
                                               "rank; a curve's long table goes in a file of its own, docs/deck-scene.md#curve)");

  std::map<std::string, KeyPlace> places;
  std::vector<Deck::InputFile> inputs;
  Reader r(path, &places, &inputs);
  try {
    std::vector<YAML::Node> docs = YAML::LoadAll(in);
    if (docs.size() > 1) r.fail(line_of(docs[1]), "", "a deck holds one YAML document (found a second one)");
    if (!docs.empty()) {
      std::vector<YAML::Node> path_to;
      std::set<size_t> done;
      check_no_cycle(r, docs[0], path_to, done);
    }
    Deck deck = parse(r, docs.empty() ? YAML::Node() : docs[0], path);
    deck.key_places = std::move(places);
    deck.input_files = std::move(inputs);
    return deck;
  } catch (const YAML::ParserException& e) {
    throw InputError(path, e.mark.line + 1, "", "YAML syntax error: " + e.msg);
  } catch (const YAML::Exception& e) {
    // Anything yaml-cpp rejects that the checks above did not foresee.
    throw InputError(path, e.mark.line >= 0 ? e.mark.line + 1 : 0, "", e.msg);
  }
}

}  // namespace hyperqn
