// The deck's section readers: each reads its section's declared keys (read_keys; the keys are
// declared beside the struct they fill), then the checks that involve several keys of that section.
// Rules between sections are in app/deck_rules.cpp.
#include "app/deck_sections.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <iterator>

#include "geometry/surface_file.hpp"
#include "io/partition_file.hpp"
#include "materials/material.hpp"
#include "materials/material_factory.hpp"
#include "model/load_kinds.hpp"
#include "materials/material_factory.hpp"
#include "solvers/solver_registry.hpp"

namespace hyperqn::deck_reading {

namespace {

// Solver names come from their registry (solvers/solver_registry.hpp).
const Names kSolverTypes = solver_names();
constexpr double kMaxBoxTets = 2147483647;  // the generator indexes tets and vertices with int32
// A generated box's or sheet's cells: the shortest side (size / cells) at least this fraction of
// the longest. An element's stiffness across a side grows as 1 / side^2: past (1e8)^2 = 1e16 the
// rest of M + h^2 L is lost to round-off and its factorization fails (measured: box cells of
// 1.5e-8 do; 1e-6 leaves a margin).
constexpr double kFlattestCell = 1e-6;

}  // namespace

// A partition file's header: what its mesh holds. The keys that shape a mesh belong to the deck
// the file was made from, and are applied in it already.
static void read_partition_header(const Reader& r, const Value& file, const Section& s, MeshSpec& m) {
  for (const char* key : {"transform", "strands", "edges", "surface"})
    if (const Value* x = s.find(key))
      r.fail(*x, "shapes the mesh, and mesh.file is a partition file: give it in the deck given to hyperqn partition "
                 "(the file holds the mesh with it applied)");
  PartitionFileInfo info;
  try {
    info = read_partition_info(m.file);
  } catch (const InputError& e) {
    r.fail(file, e.what());
  }
  if (info.bodies.count > 0)
    r.fail(file, "holds the " + std::to_string(info.bodies.count) + " bodies of a deck's bodies: name it as partition: "
                 "beside those bodies");
  m.is_partition_file = true;
  m.file_tets = info.tets;
  m.file_segments = info.segments;
  m.file_triangles = info.triangles;
  m.surface_as_cloth = info.triangles > 0;
}

void read_mesh(const Reader& r, const Value& v, const fs::path& deck_dir, MeshSpec& m) {
  Names names;  // the section's keys: unknown keys are reported before which keys go together
  for (const DeckKey<MeshSpec>& k : mesh_keys())
    if (!std::strchr(k.name, '.')) names.push_back(k.name);
  const Section s(r, v, names);
  const Value *file = s.find("file"), *box = s.find("box"), *sheet = s.find("sheet"), *strands = s.find("strands");
  if ((file != nullptr) + (box != nullptr) + (sheet != nullptr) > 1) r.fail(v, "give one of file, box and sheet");
  if (!file && !box && !sheet && !strands)
    r.fail(v, "missing the mesh: give file (a .mesh, .msh or .obj path), box, sheet or strands");
  read_keys(r, v, mesh_keys(), m);
  if (file) {
    m.file = resolve_input_file(r, *file, deck_dir, {".mesh", ".msh", ".obj", ".h5"},
                                ".mesh (Medit), .msh (Gmsh), .obj (a cloth surface) or .h5 (a partition file of hyperqn partition)");
    m.line = file->line;
    m.surface_as_cloth = m.surface_as_cloth || fs::path(m.file).extension() == ".obj";
    if (fs::path(m.file).extension() == ".h5") read_partition_header(r, *file, s, m);
  }
  if (const Value* x = s.find("surface"); x && !file)
    r.fail(*x, "surface: cloth reads the triangles of mesh.file as a cloth; give a .mesh, .msh or .obj file");
  // A generated grid's cells: its line is the mesh's (the memory check names it), its size is capped.
  const auto cells = [&](const Value& grid) {
    const Value x = *Section(r, grid, {}).find("cells");
    m.line = x.line;
    return x;
  };
  // ... and its cells are not too flat (kFlattestCell).
  const auto not_flat = [&](const Value& grid, const double* size, const int* n, int dims, const char* elements) {
    double shortest = HUGE_VAL, longest = 0;
    std::string sides;
    for (int d = 0; d < dims; ++d) {
      const double side = size[d] / n[d];
      shortest = std::min(shortest, side);
      longest = std::max(longest, side);
      char text[32];
      std::snprintf(text, sizeof text, "%s%.3g", d ? " x " : "", side);
      sides += text;
    }
    if (shortest >= kFlattestCell * longest) return;
    char rule[40];
    std::snprintf(rule, sizeof rule, "%g", kFlattestCell);
    r.fail(*Section(r, grid, {}).find("size"),
           "its cells would be " + sides + " (size / cells): the shortest side is less than " + rule +
               " of the longest, and the " + elements + "' stiffness across so thin a cell (as 1 / side^2) would bury " +
               "the rest of M + h^2 L in round-off (it would not be positive definite). Check the size and its units; a " +
               "thin plate is a cloth (mesh.sheet)");
  };
  if (sheet) {
    m.is_sheet = true;
    const Value x = cells(*sheet);
    const double triangles = 2.0 * m.sheet_cells[0] * m.sheet_cells[1];
    if (3 * triangles > kMaxBoxTets)
      r.fail(x, "makes " + std::to_string((long long)triangles) + " triangles; the sheet generator takes at most 715827882");
    not_flat(*sheet, m.sheet_size.data(), m.sheet_cells.data(), 2, "triangles");
  }
  if (m.has_cloth() && strands) r.fail(*strands, "a cloth cannot share a mesh with strands");
  if (const Value* x = s.find("edges"))
    if (m.edges_as_strands && (!file || fs::path(m.file).extension() != ".mesh" || m.surface_as_cloth))
      r.fail(*x, "edges: strands reads the Edges section of a Medit .mesh file; give one as mesh.file");
  if (strands) {
    for (const Value& item : r.items(*strands)) {
      StrandLine line;
      const Section st = read_keys(r, item, strand_line_keys(), line);
      line.line = item.line;
      if (line.from == line.to) r.fail(*st.find("to"), "a strand needs distinct from and to points");
      m.strands.push_back(line);
    }
    if (m.strands.empty()) r.fail(*strands, "expected a non-empty list of strands {from, to, segments}");
  }
  if (box) {
    m.is_box = true;
    const Value x = cells(*box);
    const double tets = 6.0 * m.box_cells[0] * m.box_cells[1] * m.box_cells[2];
    if (tets > kMaxBoxTets)
      r.fail(x, "makes " + std::to_string((long long)tets) + " tets; the box generator takes at most 2147483647");
    not_flat(*box, m.box_size.data(), m.box_cells.data(), 3, "tets");
  }
}

// hardening without yield_strain (in section s) is an error at its line.
static void hardening_needs_yield(const Reader& r, const Section& s) {
  const Value* h = s.find("hardening");
  if (h && !s.find("yield_strain"))
    r.fail(*h, "hardening is that of a yield: give yield_strain too, or leave hardening out");
}

void read_strand_material(const Reader& r, const Value& v, StrandMaterial& m) {
  hardening_needs_yield(r, read_keys(r, v, strand_material_keys(), m));
}

void read_cloth(const Reader& r, const Value& v, ClothSpec& c) {
  const Section s = read_keys(r, v, cloth_keys(), c);
  hardening_needs_yield(r, s);
  if (const Value* bending = s.find("bending")) hardening_needs_yield(r, Section(r, *bending, {}));
  if (const Value* x = s.find("thickness")) c.thickness_line = x->line;
  if (c.model == ClothModel::membrane) {
    const double e = c.youngs_modulus, n = c.poisson_ratio;
    c.mu = e / (2 * (1 + n));        // plane stress: the 2-D Lame constants of a thin sheet
    c.lambda = e * n / (1 - n * n);
  }
}

// A pair of keys that only make sense together: the missing one is reported at the other's line.
static void need_both(const Reader& r, const Section& s, const char* a, const char* b) {
  const Value *va = s.find(a), *vb = s.find(b);
  if (va && !vb) r.fail(va->line, s.path(b), std::string("missing; ") + a + " is given, so " + b + " is needed too");
  if (vb && !va) r.fail(vb->line, s.path(a), std::string("missing; ") + b + " is given, so " + a + " is needed too");
}

// The elastic constants as read_keys read them: one pair, both of it; E and nu become mu and lambda.
static void check_elastic_constants(const Reader& r, const Section& s, MaterialSpec& m) {
  const Value *E = s.find("youngs_modulus"), *nu = s.find("poisson_ratio");
  const Value *mu = s.find("mu"), *lambda = s.find("lambda");
  if ((E || nu) && (mu || lambda))
    r.fail(mu ? *mu : *lambda, "give either youngs_modulus and poisson_ratio, or mu and lambda, not both");
  if (!E && !nu && !mu && !lambda)
    r.fail(s.value(), "missing elastic constants: give youngs_modulus and poisson_ratio, or mu and lambda");
  if (E || nu) {
    need_both(r, s, "youngs_modulus", "poisson_ratio");
    m.mu = lame_mu(m.youngs_modulus, m.poisson_ratio);
    m.lambda = lame_lambda(m.youngs_modulus, m.poisson_ratio);
  } else {
    need_both(r, s, "mu", "lambda");
  }
}

// f: {polynomial: [c0, c1, ...]} or f: {spline: {x: [...], y: [...]}}
static FunctionSpec read_function(const Reader& r, const Value& v) {
  Section s(r, v, {"polynomial", "spline"});
  const Value *poly = s.find("polynomial"), *spline = s.find("spline");
  if (!poly == !spline) r.fail(v, "give either polynomial or spline");
  FunctionSpec f;
  if (poly) {
    f.kind = "polynomial";
    for (const Value& c : r.items(*poly)) f.coefficients.push_back(r.number(c));
    r.check(!f.coefficients.empty(), *poly, "a non-empty list of coefficients of (x - 1)^k");
  } else {
    f.kind = "spline";
    Section sp(r, *spline, {"x", "y"});
    const Value &x = sp.need("x"), &y = sp.need("y");
    for (const Value& c : r.items(x)) f.x.push_back(r.number(c));
    for (const Value& c : r.items(y)) f.y.push_back(r.number(c));
    r.check(f.x.size() >= 2 && f.x.size() == f.y.size(), y, "as many values as x (at least 2)");
    for (size_t i = 1; i < f.x.size(); ++i) r.check(f.x[i] > f.x[i - 1], x, "strictly increasing");
  }
  return f;
}

// A number of an inelastic block, with its declared range.
static double inelastic_number(const Reader& r, const Value& x, const MaterialKey& key) {
  const double value = r.number(x, key.range.contains(0.0));
  if (!key.range.rule().empty()) r.check(key.range.contains(value), x, key.range.rule());
  return value;
}

// An inelastic block, material.<kind.key> (its keys were checked by read_keys): its number keys,
// its list of maps of numbers (viscoelastic.branches: min_items to max_items, each key in its
// range), then the kind's rules between them, the message at the key they name.
static void read_inelastic(const Reader& r, const Value& v, const InelasticKind& kind, MaterialSpec& m) {
  InelasticSpec& spec = m.inelastic;
  spec.kind = kind.key;
  spec.line = v.line;
  const std::string prefix = std::string(kind.key) + ".";
  Names names;
  for (const MaterialKey& k : kind.keys)
    if (std::string(k.name).rfind(prefix, 0) == 0) names.push_back(std::string(k.name).substr(prefix.size()));
  const Section s(r, v, names);
  for (const MaterialKey& k : kind.keys) {
    if (std::string(k.name).rfind(prefix, 0) != 0) continue;
    const std::string name = std::string(k.name).substr(prefix.size());
    const Value* x = s.find(name);
    if (!x) continue;
    if (std::string(k.type) != "list of maps") {
      spec.values[name] = inelastic_number(r, *x, k);
      continue;
    }
    const std::vector<Value> items = r.items(*x);
    if ((int)items.size() < kind.min_items || (int)items.size() > kind.max_items)
      r.fail(*x, std::to_string(kind.min_items) + " to " + std::to_string(kind.max_items) + " " + name + ", got " +
                     std::to_string(items.size()));
    Names item_names;
    for (const MaterialKey& ik : kind.item_keys) item_names.push_back(ik.name);
    for (const Value& item : items) {
      const Section b(r, item, item_names);
      std::map<std::string, double> values;
      for (const MaterialKey& ik : kind.item_keys)
        if (const Value* y = ik.required ? &b.need(ik.name) : b.find(ik.name)) values[ik.name] = inelastic_number(r, *y, ik);
      spec.items.push_back(std::move(values));
    }
  }
  std::string key;
  if (const std::string problem = kind.check(spec, &key); !problem.empty()) {
    const Value* x = s.find(key);
    r.fail(x ? *x : v, problem);
  }
}

// The keys, ranges and models of material_keys() (from the material registry), then the rules
// that involve several keys, then the model's own checks.
void read_material(const Reader& r, const Value& v, MaterialSpec& m) {
  {
    // A model without elastic constants names the keys it takes instead (read_keys would name the
    // models that take elastic constants).
    const Section probe(r, v, {});
    const Value* word = probe.find("model");
    const MaterialModel& model = *find_material_model(word ? r.choice(*word, material_keys()[0].choices) : m.model);
    for (const MaterialKey& k : elastic_constant_keys())
      if (const Value* x = probe.find(k.name); x && !model.elastic_constants) {
        std::string own;
        for (const MaterialKey& key : model.keys) own += (own.empty() ? "" : ", ") + std::string(key.name);
        r.fail(*x, model.name + " takes " + own + " instead of elastic constants");
      }
  }
  const Section s = read_keys(r, v, material_keys(), m, {"fracture"});
  const MaterialModel& model = *find_material_model(m.model);
  if (const Value* x = s.find("fracture")) {  // docs/topology.md#fracture
    read_keys(r, *x, fracture_keys(), m.fracture);
    m.fracture.given = true;
    m.fracture.line = x->line;
    // The criteria are values of the tets' stress and energy density, which the mass-spring model has not.
    if (!model.create)
      r.fail(*x, m.model + " tets have no stress or energy density, which fracture's criteria are: give a continuum "
                           "model (docs/topology.md#fracture)");
  }
  if (model.elastic_constants) check_elastic_constants(r, s, m);
  if (const Value* x = s.find("f")) m.f = read_function(r, *x);
  if (const Value* x = s.find("g")) m.g = read_function(r, *x);
  if (const Value* x = s.find("h")) m.h = read_function(r, *x);
  // A model of functions (principal-stretch) needs one of them.
  const bool of_functions = std::any_of(model.keys.begin(), model.keys.end(),
                                        [](const MaterialKey& k) { return std::string(k.type) == "function"; });
  if (of_functions && m.f.kind.empty() && m.g.kind.empty() && m.h.kind.empty())
    r.fail(v, m.model + " needs f, g or h");
  m.has_fiber = s.find("fiber") != nullptr;
  // One inelastic block at most: a material is viscoelastic or plastic (or elastic).
  for (const InelasticKind& kind : inelastic_kinds())
    if (const Value* x = s.find(kind.key)) {
      if (!m.inelastic.kind.empty())
        r.fail(*x, "a material takes one inelastic block, and this one has " + m.inelastic.kind + " (deck line " +
                       std::to_string(m.inelastic.line) + ") too: give one of the two");
      read_inelastic(r, *x, kind, m);
    }

  const Value *density = s.find("density"), *total = s.find("total_mass");
  if (density && total) r.fail(*total, "give either density or total_mass, not both");
  if (!density && !total) r.fail(v, "missing the mass: give density or total_mass");
  m.has_density = density != nullptr;

  // The material's own checks (e.g. spline shapes) with the deck's place in the message.
  try {
    if (model.create) make_material(m);
  } catch (const std::invalid_argument& e) {
    r.fail(v, e.what());
  }
}

// A box of fixed:, attachments: or regions:, read by read_keys (box_keys): min <= max on every axis.
static void check_box(const Reader& r, const Section& s, const BoxRegion& b) {
  const Value* box = s.find("box");
  if (!box) return;
  const Section corners(r, *box, {});
  for (int i = 0; i < 3; ++i)
    if (b.min[i] > b.max[i])
      r.fail(*box, std::string("min > max along ") + "xyz"[i] + ": " + r.items(*corners.find("min"))[i].node.Scalar() +
                       " > " + r.items(*corners.find("max"))[i].node.Scalar());
}

void read_curve(const Reader& r, const Value& v, Curve& c) {
  const Section s = read_keys(r, v, curve_keys(), c);
  c.given = true;
  if (c.type == CurveType::ramp)
    if (const Value* end = s.find("end")) r.check(c.end > c.start, *end, "> start (" + default_text(c.start) + ")");
  if (c.type != CurveType::table) return;
  const Value *points = s.find("points"), *file = s.find("file");
  if ((points != nullptr) == (file != nullptr)) r.fail(v, "a table gives its points or a file of them (one of the two)");
  if (points) {
    const std::vector<Value> items = r.items(*points);
    for (const Value& item : items) c.points.push_back(r.numbers<2>(item));
    size_t at = 0;
    if (const std::string problem = curve_table_problem(c.points, at); !problem.empty())
      r.fail(c.points.size() < 2 ? *points : items[at], problem);
    return;
  }
  c.file = resolve_input_file(r, *file, r.deck_dir(), {".csv"}, ".csv (a row 't, v' per point)");
  try {
    c.points = read_curve_table(c.file);
  } catch (const std::runtime_error& e) {
    r.fail(*file, e.what());
  }
}

static Motion read_motion(const Reader& r, const Value& v) {
  Motion m;
  const Section s = read_keys(r, v, motion_keys(), m);
  m.active = true;
  if (const Value* curve = s.find("curve")) {
    for (const char* key : {"start", "end"})
      if (const Value* x = s.find(key))
        r.fail(*x, "a motion with a curve moves as its curve says (a ramp's start and end, a table's times): give "
                   "either start and end or curve");
    read_curve(r, *curve, m.curve);
    // The vertices and obstacles start where the mesh and the deck put them.
    const double c0 = m.curve.value(0);
    if (!(std::fabs(c0) <= 1e-12 * m.curve.magnitude()))
      r.fail(*curve, "is " + default_text(c0) + " at t = 0, and a motion's curve starts at 0 (the motion starts at "
                     "the rest positions): shift it (a sine's offset or phase, the table's values)");
  }
  if (const Value* x = s.find("end")) r.check(m.end >= m.start, *x, ">= motion.start");
  return m;
}

// body >= 0: bodies[body].fixed, which selects that body's vertices only.
void read_fixed(const Reader& r, const Value& v, std::vector<BoxRegion>& fixed, int body) {
  for (const Value& item : r.items(v)) {
    BoxRegion b;
    const Section s = read_keys(r, item, fixed_keys(), b);
    check_box(r, s, b);
    b.line = item.line;
    b.has_box = s.find("box") != nullptr;
    if (const Value* tag = s.find("face_tag")) {
      b.face_tag = r.integer(*tag);
      b.has_face_tag = true;
      b.face_tag_line = tag->line;
    } else if (!b.has_box) {
      r.fail(item, "give box or face_tag (or both)");
    }
    b.body = body;
    if (const Value* x = s.find("motion")) b.motion = read_motion(r, *x);
    if (const Value* x = s.find("components")) {
      b.components_line = x->line;
      for (size_t i = 0; i < b.components.size(); ++i)
        if (std::count(b.components.begin(), b.components.begin() + i, b.components[i]))
          r.fail(*x, "names " + b.components[i] + " twice: each component is held once");
    }
    fixed.push_back(b);
  }
}

// bodies: a list of bodies, each a mesh (tets, a cloth, strands, or tets with strands, with its
// transform) with the material of each of its parts, an initial velocity and its own fixed regions
// and attachments (returned in regions, read after the scene's).
void read_bodies(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck, BodyRegions& regions) {
  for (const Value& item : r.items(v)) {
    const int k = (int)deck.bodies.size();
    BodySpec b;
    b.line = item.line;
    b.name = "body" + std::to_string(k);
    const Section s = read_keys(r, item, body_keys(), b);
    for (const BodySpec& other : deck.bodies)  // a given name, or the default bodyK another body took
      if (other.name == b.name) {
        const std::string where = " (line " + std::to_string(other.line) + ")";
        if (const Value* x = s.find("name")) r.fail(*x, "another body is named " + b.name + where);
        r.fail(item, "this body's default name " + b.name + " is another body's" + where + ": give it a name");
      }
    const Value& mesh = *s.find("mesh");
    read_mesh(r, mesh, deck_dir, b.mesh);
    const MeshSpec& m = b.mesh;
    if (m.is_partition_file)
      r.fail(mesh, "a body's mesh is not a partition file: name the partition file of all the bodies as partition: "
                   "beside bodies: (written by hyperqn partition DECK -n N)");
    // Each part of the body's mesh takes its own material, read as for a scene of one body. A
    // Medit file read for its edges may hold no tets (load_scene_input checks).
    const struct {
      const char* key;
      bool has;
      bool required;
      const char* part;
    } parts[] = {{"material", m.has_solid(), m.has_solid() && !m.edges_as_strands, "tetrahedra (a box or a .mesh or .msh file)"},
                 {"cloth", m.has_cloth(), m.has_cloth(), "a cloth (a sheet, an .obj file, or a file with surface: cloth)"},
                 {"strand_material", m.has_strands(), m.has_strands(), "strands (mesh.strands, or edges: strands)"}};
    for (const auto& part : parts) {
      const Value* x = s.find(part.key);
      if (x && !part.has) r.fail(*x, std::string(part.key) + " describes " + part.part + ", and the body's mesh has none");
      if (part.required) s.need(part.key);
    }
    if (const Value* x = s.find("material")) {
      read_material(r, *x, b.material);
      b.has_material = true;
    }
    if (const Value* x = s.find("cloth")) read_cloth(r, *x, b.cloth);
    if (const Value* x = s.find("strand_material")) read_strand_material(r, *x, b.strand_material);
    if (const Value* x = s.find("velocity")) b.velocity_line = x->line;
    if (const Value* x = s.find("fixed")) regions.fixed.emplace_back(k, *x);
    if (const Value* x = s.find("attachments")) regions.attachments.emplace_back(k, *x);
    deck.bodies.push_back(b);
  }
  r.check(!deck.bodies.empty(), v, "a non-empty list");
  for (const BodySpec& b : deck.bodies)
    if (b.has_material) {  // the scene's material (what the study names): the first body's with tets
      deck.material = b.material;
      deck.has_material = true;
      break;
    }
  deck.mesh.line = deck.bodies[0].mesh.line;
}

// partition: the file `hyperqn partition` writes of the joined bodies. It need not exist yet (the
// command writes it from this deck); the run checks it against the bodies (load_scene_input).
void read_bodies_partition(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck) {
  const fs::path file = r.text(v);
  if (file.extension() != ".h5")
    r.fail(v, "'" + file.string() + "': a partition file's name ends in .h5 (hyperqn partition DECK -n N writes it)");
  deck.partition_file = (file.is_absolute() ? file : (deck_dir / file).lexically_normal()).string();
  deck.partition_line = v.line;
  r.note_input(deck.partition_file, v);  // need not exist yet
}

// colliders: a list of obstacles, each of one type with that type's keys (collider_keys()).
void read_colliders(const Reader& r, const Value& v, const fs::path& deck_dir, std::vector<ColliderSpec>& colliders) {
  for (const Value& item : r.items(v)) {
    ColliderSpec c;
    const Section s = read_keys(r, item, collider_keys(), c);
    c.line = item.line;
    if (c.type == ColliderType::box)
      for (int i = 0; i < 3; ++i)
        if (!(c.min[i] < c.max[i]))
          r.fail(*s.find("max"), std::string("must exceed min along ") + "xyz"[i] + " (a solid box of positive size)");
    if (c.type == ColliderType::mesh)
      c.file = resolve_input_file(r, *s.find("file"), deck_dir, {".obj", ".mesh"},
                                  ".obj (Wavefront) or .mesh (Medit, its Triangles)");
    if (const Value* x = s.find("motion")) c.motion = read_motion(r, *x);
    colliders.push_back(c);
  }
}

void read_contact(const Reader& r, const Value& v, ContactSpec& c) {
  const Section s = read_keys(r, v, contact_keys(), c);
  c.line = v.line;
  if (const Value* x = s.find("distance")) c.distance_line = x->line;
  if (const Value* x = s.find("self_distance")) c.self_distance_line = x->line;
  if (const Value* x = s.find("self_friction"); x && !c.self)
    r.fail(*x, "self_friction is the friction between surfaces in self-contact, which is off (self: true turns it on); "
               "each collider has its own friction");
  if (const Value* x = s.find("self_distance"); x && !c.self)
    r.fail(*x, "self_distance is the activation distance between surfaces in self-contact, which is off (self: true "
               "turns it on); the colliders' is distance");
}

// attachments: [{box, stiffness, motion, release}]: box, motion and release as for fixed regions.
void read_attachments(const Reader& r, const Value& v, std::vector<AttachmentSpec>& attachments) {
  for (const Value& item : r.items(v)) {
    AttachmentSpec a;
    const Section s = read_keys(r, item, attachment_keys(), a);
    check_box(r, s, a.region);
    a.region.line = item.line;
    if (const Value* x = s.find("motion")) a.region.motion = read_motion(r, *x);
    attachments.push_back(a);
  }
}

// A surface blade's file: read (on every rank), transformed, its zero-area triangles dropped; an
// unreadable file or one with no triangle (with an area) is refused at the deck line.
static void read_blade_surface(const Reader& r, const Value& file, CutSpec& c) {
  c.surface = resolve_input_file(r, file, r.deck_dir(), {".obj", ".mesh"}, ".obj (Wavefront) or .mesh (Medit, its Triangles)");
  TriangleSurface surface;
  try {
    surface = read_triangle_surface(c.surface);
  } catch (const std::exception& e) {
    r.fail(file, e.what());
  }
  const Eigen::Vector3d offset(c.surface_offset[0], c.surface_offset[1], c.surface_offset[2]);
  for (const Eigen::Vector3d& x : surface.vertices) c.mesh_vertices.push_back(c.surface_scale * x + offset);
  for (const auto& t : surface.triangles) {
    const Eigen::Vector3d& p = c.mesh_vertices[t[0]];
    if ((c.mesh_vertices[t[1]] - p).cross(c.mesh_vertices[t[2]] - p).norm() > 0) c.mesh_triangles.push_back(t);
  }
  if (c.mesh_triangles.empty()) r.fail(file, "the surface file '" + c.surface + "' holds no triangle with an area");
  index_blade_surface(c);
}

// cuts: [{center, normal, axis, size | surface, motion}]: scripted cuts (geometry/blade.hpp, docs/topology.md).
void read_cuts(const Reader& r, const Value& v, std::vector<CutSpec>& cuts) {
  for (const Value& item : r.items(v)) {
    CutSpec c;
    const Section s = read_keys(r, item, cut_keys(), c);
    c.line = item.line;
    if (const Value* file = s.find("surface")) {
      for (const char* key : {"center", "normal", "axis", "size"})
        if (const Value* x = s.find(key)) r.fail(*x, "is a key of the rectangle blade: not with surface (a triangle mesh)");
      read_blade_surface(r, *file, c);
    } else {
      for (const char* key : {"center", "normal", "axis", "size"})
        if (!s.find(key)) r.fail(item, std::string("missing ") + key + ": give center, normal, axis and size (a rectangle) or surface (a triangle mesh)");
      for (const char* key : {"surface_scale", "surface_offset"})
        if (const Value* x = s.find(key)) r.fail(*x, "transforms a surface: give it with surface only");
      const Eigen::Vector3d n(c.normal[0], c.normal[1], c.normal[2]), a(c.axis[0], c.axis[1], c.axis[2]);
      if ((a - a.dot(n.normalized()) * n.normalized()).norm() <= 1e-9 * a.norm())
        r.fail(*s.find("axis"), "is along normal: the rectangle's first side must lie in the blade's plane");
    }
    if (const Value* x = s.find("motion")) {
      c.motion = read_motion(r, *x);
      if (const std::string problem = blade_motion_problem(c); !problem.empty()) r.fail(*x, problem);
    }
    cuts.push_back(c);
  }
}

// loads: [{type, box, normal, angle, <the type's keys>}] (model/load_kinds.hpp).
void read_loads(const Reader& r, const Value& v, std::vector<LoadSpec>& loads) {
  for (const Value& item : r.items(v)) {
    LoadSpec l;
    const Section s = read_keys(r, item, load_keys(), l);
    l.has_box = s.find("box") != nullptr;
    if (const Value* tag = s.find("face_tag")) {
      l.face_tag = r.integer(*tag);
      l.has_face_tag = true;
      l.face_tag_line = tag->line;
    } else if (!l.has_box) {
      r.fail(item, "give box or face_tag (or both)");
    }
    if (const Value* box = s.find("box")) {
      const Section corners(r, *box, {});
      for (int i = 0; i < 3; ++i)
        if (l.min[i] > l.max[i])
          r.fail(*box, std::string("min > max along ") + "xyz"[i] + ": " + r.items(*corners.find("min"))[i].node.Scalar() +
                           " > " + r.items(*corners.find("max"))[i].node.Scalar());
    }
    if (const Value* x = s.find("normal"); x && find_load_kind(l.type)->target != LoadTarget::faces)
      r.fail(*x, "selects faces by their normal; a " + l.type + " load acts on vertices");
    if (const Value* x = s.find("angle"); x && !s.find("normal")) r.fail(*x, "is the cone of `normal`, which is not given");
    if (const Value* x = s.find("curve")) read_curve(r, *x, l.curve);
    l.line = item.line;
    loads.push_back(l);
  }
}

// Each body's own fixed regions and attachments (BoxRegion::body), after the scene's.
void read_body_regions(const Reader& r, const BodyRegions& regions, Deck& deck) {
  for (const auto& [k, item] : regions.fixed) read_fixed(r, item, deck.fixed, k);
  for (const auto& [k, item] : regions.attachments) {
    std::vector<AttachmentSpec> own;
    read_attachments(r, item, own);
    for (AttachmentSpec& a : own) {
      a.region.body = k;
      deck.attachments.push_back(a);
    }
  }
}

void read_initial(const Reader& r, const Value& v, InitialSpec& in) {
  const Section s(r, v, {"squash", "collapse", "random", "invert"});
  if (s.entries().size() != 1) r.fail(v, "give exactly one of squash, collapse, random, invert");
  read_keys(r, v, initial_keys(), in);
  const auto& [form, x] = s.entries()[0];
  if (form == "squash") in.kind = InitialKind::squash;
  if (form == "collapse" && r.boolean(x)) in.kind = InitialKind::collapse;
  if (form == "random") in.kind = InitialKind::random;
  if (form == "invert") in.kind = InitialKind::invert;
}

void read_regions(const Reader& r, const Value& v, const MaterialSpec& base, std::vector<MaterialRegion>& regions) {
  for (const Value& item : r.items(v)) {
    MaterialRegion region;
    const Section s = read_keys(r, item, region_keys(), region);
    region.line = item.line;
    const Value *box = s.find("box"), *tags = s.find("tags");
    if (!box == !tags) r.fail(item, "give either box or tags");
    check_box(r, s, region.box);
    region.by_box = box != nullptr;
    if (box) region.box.line = box->line;
    const Value& mat = *s.find("material");
    read_material(r, mat, region.material);
    // Masses are per unit volume when the body has several materials.
    if (!region.material.has_density || !base.has_density)
      r.fail(mat, "with regions, every material (the default one too) gives density, not total_mass");
    regions.push_back(region);
  }
}

// An integrator's name (study.integrators; time.integrator is read by time_keys()).
static TimeIntegrator read_integrator(const Reader& r, const Value& v) {
  return integrator_named(r.choice(v, integrator_names()))->kind;
}

void read_time(const Reader& r, const Value& v, TimeSpec& t) {
  const Section s = read_keys(r, v, time_keys(), t);
  if (const Value* x = s.find("dt")) r.check(t.dt >= 1e-100, *x, ">= 1e-100 (h^2 must not underflow)");
  const bool quasi_static = t.integrator == TimeIntegrator::quasi_static;
  if (const Value* x = s.find("pseudo_step"); x && !quasi_static)
    r.fail(*x, "pseudo_step is the static integrator's (integrator: static): leave it out");
  if (const Value* x = s.find("pseudo_step")) t.pseudo_step_line = x->line;  // its range needs the mesh (LiveScene::build)
  // A static step has no velocity to damp.
  if (const Value* x = s.find("damping"); x && quasi_static)
    r.fail(*x, "integrator: static has no velocities to damp (each frame is an equilibrium): leave damping out");
}

void read_solver(const Reader& r, const Value& v, SolverSpec& sv) {
  const Section s = read_keys(r, v, solver_keys(), sv);
  // lbfgs only, like the other solvers' own keys (pd is defined by M + h^2 L). amg would not
  // be ignored by pd but break it: its steps are exact solves with M + h^2 L.
  if (const Value* x = s.find("h0"); x && sv.type == "pd" && sv.h0 == H0::amg)
    r.fail(*x, "amg is for lbfgs: pd's steps need the exact solve with M + h^2 L, which a V-cycle only "
               "approximates (give laplacian, or leave h0 out)");
  // single: a factor's values (pd's steps are exact solves with M + h^2 L; a V-cycle has no factor).
  if (const Value* x = s.find("h0_precision"); x && sv.h0_precision == H0Precision::single_precision) {
    if (sv.type == "pd")
      r.fail(*x, "single is for lbfgs: pd's steps need the exact solve with M + h^2 L (give double, or leave "
                 "h0_precision out)");
    if (sv.h0 == H0::amg)
      r.fail(*x, "single rounds a factor's values, and h0: amg factors nothing (give double, or leave h0_precision "
                 "out)");
  }
  // true: a correction of M + h^2 L (solvers/rigid_mode_h0.hpp), which the other matrices are not.
  if (const Value* x = s.find("h0_rigid");
      x && sv.h0_rigid == H0Rigid::on && sv.h0 != H0::automatic && sv.h0 != H0::laplacian)
    r.fail(*x, "true corrects M + h^2 L's rotations of stiff parts, and h0: " + kH0Names[(int)sv.h0] +
                   " is another matrix (give h0: laplacian or auto, or leave h0_rigid out)");
  // woodbury: a correction of the factor of A = A1 (x) I3 (solvers/contact_h0.hpp), which the full 3n x 3n
  // matrices are not (before, silently off).
  if (const Value* x = s.find("h0_contact");
      x && sv.h0_contact == H0Contact::woodbury && (sv.h0 == H0::rest_stiffness || sv.h0 == H0::volumetric))
    r.fail(*x, "woodbury corrects the factor of M + h^2 L (A1 (x) I3), and h0: " + kH0Names[(int)sv.h0] +
                   " is a full 3n x 3n matrix (give refactor, which takes any, or h0: laplacian or auto)");
  // adaptive: the fallback chain as the keys above set it; fixed: none of it, and then
  // those keys would say nothing, so giving one is an error rather than silently overruled.
  if (const Value* x = s.find("budget"); x && x->node.Scalar() == "fixed")
    for (const char* key : {"max_iterations", "max_halvings", "newton_fallback", "keep_substeps"})
      if (const Value* stage = s.find(key))
        r.fail(*stage, std::string("budget: fixed turns off the fallback chain (") + key +
                           " among it): leave " + key + " out, or use budget: adaptive");
}

void read_study(const Reader& r, const Value& v, int scene_frames, StudySpec& st) {
  const Section s = read_keys(r, v, study_keys(), st);
  if (const Value* x = s.find("frames")) {
    std::vector<int> seen;
    for (const Value& item : r.items(*x)) {
      r.check(r.integer(item) >= 1 && r.integer(item) <= scene_frames, item, "a frame in [1, time.frames = " + std::to_string(scene_frames) + "]");
      r.check(std::find(seen.begin(), seen.end(), r.integer(item)) == seen.end(), item, "a frame not listed before");
      seen.push_back(r.integer(item));
    }
  }
  // Each solver once: its rows are keyed by its name (study.csv, trajectory.csv, study.h5's groups).
  if (const Value* x = s.find("solvers")) {
    std::vector<std::string> seen;
    for (const Value& item : r.items(*x)) {
      r.check(std::find(seen.begin(), seen.end(), item.node.Scalar()) == seen.end(), item, "a solver not listed before");
      seen.push_back(item.node.Scalar());
    }
  }
  if (const Value* x = s.find("integrators")) {
    for (const Value& item : r.items(*x)) {
      const TimeIntegrator kind = read_integrator(r, item);
      r.check(std::find(st.integrators.begin(), st.integrators.end(), kind) == st.integrators.end(), item,
              "each integrator once");
      st.integrators.push_back(kind);
    }
    r.check(!st.integrators.empty(), *x, "a non-empty list");
  }
  if (const Value* x = s.find("trajectory_iterations")) {
    if (!st.trajectory) r.fail(*x, "budgets the trajectories, and study.trajectory is false (leave it out)");
    Section t(r, *x, kSolverTypes);
    for (const auto& [name, item] : t.entries()) {
      st.trajectory_iterations[name] = r.integer(item);
      r.check(st.trajectory_iterations[name] >= 1, item, ">= 1");
      if (std::find(st.solvers.begin(), st.solvers.end(), name) == st.solvers.end())
        r.fail(item, name + " is not among study.solvers (" + join(st.solvers) + "): a budget for no trajectory");
    }
  }
}

void read_output(const Reader& r, const Value& v, OutputSpec& o) {
  const Section s = read_keys(r, v, output_keys(), o);
  if (const Value* fields = s.find("fields"))
    for (const Value& item : r.items(*fields)) {  // the choices are checked: each a field's name
      if (std::count(o.fields.begin(), o.fields.begin() + o.field_lines.size(), item.node.Scalar()))
        r.fail(item, item.node.Scalar() + " is listed twice");
      o.field_lines.push_back(item.line);
    }
}

void read_checkpoint(const Reader& r, const Value& v, CheckpointSpec& c) { read_keys(r, v, checkpoint_keys(), c); }

void read_guardrails(const Reader& r, const Value& v, GuardrailSpec& g) { read_keys(r, v, guardrail_keys(), g); }

// petsc: {a: {b: 1}} -> ("-a_b", "1"). Values go to PETSc as written, except that booleans are
// spelled true/false and an empty value is "" (an option without argument).
void read_petsc(const Reader& r, const Value& v, const std::string& prefix, Deck& deck, int depth) {
  auto& out = deck.petsc_options;
  if (depth > kMaxPetscDepth) r.fail(v, "nested more than " + std::to_string(kMaxPetscDepth) + " levels deep");
  const Section s = read_keys(r, v, petsc_keys(), deck);
  for (const auto& [name, x] : s.entries()) {
    if ((int)out.size() >= kMaxPetscOptions)
      r.fail(x, "more than " + std::to_string(kMaxPetscOptions) + " PETSc options (YAML aliases repeating maps?)");
    if (name.empty() || name[0] == '-')
      r.fail(x, "PETSc option names are written without the leading '-'");
    // PETSc would take anything else as the end of the name, or as another option.
    const bool plain = std::all_of(name.begin(), name.end(), [](char c) { return std::isalnum((unsigned char)c) || c == '_'; });
    if (!plain || (prefix.empty() && !std::isalpha((unsigned char)name[0])))
      r.fail(x, "not a PETSc option name: letters, digits and '_' only, starting with a letter");
    std::string option = prefix.empty() ? name : prefix + "_" + name;
    if (option == "options_file" || option == "options_file_yaml")  // set now, it would be read by nothing
      r.fail(x, "PETSc reads options files only as it starts: give -" + option + " FILE on the command line");
    if (x.node.IsMap()) {
      read_petsc(r, x, option, deck, depth + 1);
      continue;
    }
    std::string value;
    if (x.node.IsScalar()) {
      value = x.node.Scalar();
      if (x.node.Tag() != "!") {  // plain, not quoted
        // true: the option alone, which PETSc reads as true, and a viewer option (log_view, tao_view)
        // as its default viewer; "-log_view true" would be a viewer named true.
        if (value == "true" || value == "True" || value == "TRUE") value.clear();
        if (value == "False" || value == "FALSE") value = "false";
        static const char* const yaml11[] = {"y", "Y", "yes", "Yes", "YES", "n", "N", "no", "No", "NO",
                                             "on", "On", "ON", "off", "Off", "OFF"};
        if (std::find(std::begin(yaml11), std::end(yaml11), value) != std::end(yaml11))
          r.fail(x, "expected true or false, got " + value + " (a deck's booleans are YAML 1.2's; quote it to pass the word)");
      }
      // PETSc splits a value at whitespace: "unit -tao_type x" would set a second option.
      if (std::any_of(value.begin(), value.end(), [](char c) { return std::isspace((unsigned char)c) || std::iscntrl((unsigned char)c); }))
        r.fail(x, "a PETSc option value is one word: no spaces or control characters, got " + describe(x.node));
    } else if (!x.node.IsNull()) {
      r.fail(x, "expected a single value or a nested map, got " + describe(x.node) +
                    " (write PETSc lists as a comma-separated string)");
    }
    if (const auto seen = deck.petsc_option_places.find("-" + option); seen != deck.petsc_option_places.end())
      r.fail(x, "option -" + option + " is also given at line " + std::to_string(seen->second.line) +
                    " (as '" + seen->second.key + "')");
    out.emplace_back("-" + option, value);
    deck.petsc_option_places["-" + option] = {x.line, x.key};
  }
}

}  // namespace hyperqn::deck_reading
