// A scene as the deck describes it: mesh, materials, regions, initial state, gravity and time
// stepping. The deck (app/deck.hpp) is a scene plus how to run it (solver, output, study); the
// model builds from this alone.
#pragma once
#include <algorithm>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "geometry/blade.hpp"
#include "geometry/collider.hpp"
#include "params/deck_keys.hpp"
#include "mesh/mesh_spec.hpp"
#include "model/material_spec.hpp"
#include "model/regions.hpp"
#include "model/time_integrator.hpp"
#include "terms/contact_spec.hpp"
#include "terms/load_spec.hpp"

namespace hyperqn {

struct TimeSpec {
  double dt = 1.0 / 30.0;
  int frames = 100;
  double damping = 0;                // v <- (1 - damping) v after each step
  TimeIntegrator integrator = TimeIntegrator::implicit_euler;
  double pseudo_step = 0;            // static: s of H0 = (M + s^2 L)^-1 (0: automatic)
  int pseudo_step_line = 0;          // its deck line
};

// The deck's time: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<TimeSpec>>& time_keys() {
  static const std::vector<DeckKey<TimeSpec>> keys = {
      {"dt", &TimeSpec::dt, "time step (one step per frame)", above(0), {}, "s", "1/30"},
      {"frames", &TimeSpec::frames, "number of time steps", between(1, 1e8)},
      {"damping", &TimeSpec::damping, "after each step, v ← (1 − damping) v", {0, 1, false, true}},
      {"integrator", std::monostate{},
       "the time integrator ([method.md](method.md#time-integrators)): `bdf2` is second order and L-stable and damps "
       "less than implicit Euler but still damps (a free bar from a 5 % stretch at h = 5 ms: 48 % of its energy lost "
       "in 10 steps, Euler 93 %, both all of it in 2,000), 4 of the 21 stability cases degraded (Euler 6); "
       "`implicit-midpoint` is second order and keeps the energy of vibrations that implicit Euler damps out; a step "
       "whose end would invert or blow up a tet, or make springs' or cloth's energy out of nothing, is completed by "
       "implicit Euler instead (`euler_completed_steps` in "
       "`summary.json`), so it fails no stability case, but it is best in calm scenes (7 of the 21 cases degraded); "
       "not with `colliders` (a deck error); `static`: each frame a load step to equilibrium at the loads and fixed "
       "regions of its end, no inertia, velocities 0 ([method.md](method.md#time-integrators)); needs a `fixed` region, "
       "an attachment or a collider (with `bodies`, each body a region of its own or the deck's, unless contact may "
       "hold it: a collider, or self-contact with `model: barrier`; the penalty holds no static body), and takes no `damping` nor a body's `velocity`",
       {}, integrator_names(), "", "",
       [](TimeSpec& t, const std::string& name) { t.integrator = integrator_named(name)->kind; },
       [](const TimeSpec& t) { return std::string(integrator_info(t.integrator).name); }},
      {"pseudo_step", &TimeSpec::pseudo_step,
       "`static` only: the pseudo step s of L-BFGS's H0 = (M + s²L)⁻¹ (and Newton's M + s²K), where M only "
       "regularizes what the supports leave free; within 1e-4 to 1e4 times the automatic one (else g underflows or "
       "overflows)",
       above(0), {}, "s", "auto: s² = 10⁸ N^(2/3) max m_i / L_ii over the N free vertices"},
  };
  return keys;
}

// The deck's mesh: keys (params/deck_keys.hpp; MeshSpec is the mesh layer's, below io). Its reader
// resolves the file, reads the strands (strand_line_keys) and checks which keys go together.
inline const std::vector<DeckKey<MeshSpec>>& mesh_keys() {
  using M = MeshSpec;
  static const std::vector<DeckKey<M>> keys = [] {
    std::vector<DeckKey<M>> k = {
        {"file", &M::file,
         "tetrahedral mesh file: `.mesh` (Medit) or `.msh` (Gmsh), or a cloth surface: `.obj` (Wavefront), or "
         "`.mesh`/`.msh` with `surface: cloth`, or a partition file `.h5` written by `hyperqn partition` (below). A "
         "relative path is resolved against **the deck's directory**, not the working directory. An absolute path is "
         "used as written. The file must exist.",
         {}, {}, "", "none"},
        map_key<M>("box", "a generated box of tetrahedra", "none"),
        needed(DeckKey<M>{"box.size", &M::box_size, "generated box `[0, size]` in x, y and z (length)", above(0)}),
        needed(DeckKey<M>{"box.cells", &M::box_cells, "cubes along x, y and z, with 6 tetrahedra per cube",
                          at_least(1)}),
        map_key<M>("sheet", "a generated cloth sheet", "none"),
        needed(DeckKey<M>{"sheet.size", &M::sheet_size,
                          "generated flat cloth in the x-z plane from (0, 0, 0) to (size[0], 0, size[1])", above(0)}),
        needed(DeckKey<M>{"sheet.cells", &M::sheet_cells,
                          "cells along x and z, 2 triangles per cell (alternating diagonals): (cells[0] + 1) × "
                          "(cells[1] + 1) vertices",
                          at_least(1)}),
        {"surface", std::monostate{},
         "the triangles of the `.mesh` (`Triangles` section) or `.msh` (type 2) `file` are a cloth; its tetrahedra are "
         "not read. Implied for `.obj`.",
         {}, {"cloth"}, "", "none (implied for `.obj`)", [](M& m, const std::string&) { m.surface_as_cloth = true; }},
        map_key<M>("transform", "applied to the file or box mesh before anything else (not to `strands`)", "none"),
        {"transform.scale", Field<M, double>([](M& m) -> double& { return m.transform.scale; }),
         "uniform scale factor", above(0)},
        {"transform.rotate", Field<M, Array3>([](M& m) -> Array3& { return m.transform.rotate_deg; }),
         "rotations in degrees about x, then y, then z"},
        {"transform.translate", Field<M, Array3>([](M& m) -> Array3& { return m.transform.translate; }),
         "translation (length)"},
        {"edges", std::monostate{},
         "`strands`: the `Edges` section of the Medit `file` becomes strand segments (the file may hold only "
         "`Vertices` and `Edges`). Tet mesh generators write `Edges` for feature lines, hence the default `ignore`. "
         "Needs a `.mesh` file.",
         {}, {"ignore", "strands"}, "", "",
         [](M& m, const std::string& word) { m.edges_as_strands = word == "strands"; },
         [](const M& m) { return std::string(m.edges_as_strands ? "strands" : "ignore"); }},
        custom_key<M>("strands", "list of `{from: vec3, to: vec3, segments: integer ≥ 1}`",
                      "generated straight strands, each cut into `segments` equal segments, in world coordinates "
                      "(after the transform)",
                      "none"),
    };
    return k;
  }();
  return keys;
}

// The keys of one of mesh.strands (params/deck_keys.hpp; documented as mesh_keys' strands).
inline const std::vector<DeckKey<StrandLine>>& strand_line_keys() {
  using L = StrandLine;
  static const std::vector<DeckKey<L>> keys = {
      needed(DeckKey<L>{"from", &L::from, "one end"}),
      needed(DeckKey<L>{"to", &L::to, "the other end"}),
      needed(DeckKey<L>{"segments", &L::segments, "equal segments", at_least(1)}),
  };
  return keys;
}

// An extreme initial state (positions at frame 0; the rest shape stays the mesh). c is the
// centre of the rest bounding box; fixed vertices stay where they are.
enum class InitialKind { rest, squash, collapse, random, invert };

struct InitialSpec {
  InitialKind kind = InitialKind::rest;  // the deck's form (rest: none)
  int axis = 1;                      // squash, invert: the coordinate axis (0, 1, 2)
  double factor = 0;                 // squash: x_A = c_A + factor (X_A - c_A)
  int seed = 1;                      // random: uniform in the rest bounding box, per vertex id
};

// The deck's initial: keys (params/deck_keys.hpp): one form, a map of its own keys (collapse: a bool).
// Its reader checks that one is given and sets kind.
inline const std::vector<DeckKey<InitialSpec>>& initial_keys() {
  using I = InitialSpec;
  static const std::vector<DeckKey<I>> keys = {
      map_key<I>("squash", "coordinate `axis` of every free vertex scaled by `factor` about c", "none"),
      needed(DeckKey<I>{"squash.axis", &I::axis, "the axis: 0, 1, 2 for x, y, z", between(0, 2, "x, y or z")}),
      needed(DeckKey<I>{"squash.factor", &I::factor, "the scale s (s = 0: flat, J = 0)", at_least(0)}),
      custom_key<I>("collapse", "bool", "`true`: every free vertex at c (F = 0)", "false"),
      map_key<I>("random", "every free vertex at a uniformly random point of the rest bounding box", "none"),
      {"random.seed", &I::seed,
       "drawn per input vertex id from this seed (the same at any rank count)"},
      map_key<I>("invert", "every free vertex mirrored through the plane through c normal to `axis` (every element "
                           "inverted)",
                 "none"),
      needed(DeckKey<I>{"invert.axis", &I::axis, "the axis: 0, 1, 2 for x, y, z", between(0, 2, "x, y or z")}),
  };
  return keys;
}

// One body of a scene of several (deck bodies:): its own mesh (tets, a cloth, strands, or tets
// with strands), with its transform, the material of each of its parts, and initial velocity; its
// fixed regions and attachments are in SceneSpec::fixed and ::attachments with BoxRegion::body set. All bodies go into one mesh (vertex ids body by body), one factor, one solve.
struct BodySpec {
  std::string name;                      // bodies[k].name, default body<k>
  MeshSpec mesh;
  MaterialSpec material;                 // of its tets (if has_material)
  bool has_material = false;
  ClothSpec cloth;                       // of its triangles (if mesh.has_cloth())
  StrandMaterial strand_material;        // of its strand segments (if mesh.has_strands())
  std::array<double, 3> velocity{0, 0, 0};
  int line = 0;                          // deck line of bodies[k]
  int velocity_line = 0;                 // of its velocity (0: not given)
};

// The keys of one of the deck's bodies (params/deck_keys.hpp). Its reader reads the mesh and the
// material of each part with their sections' own keys, and checks which parts the mesh has.
inline const std::vector<DeckKey<BodySpec>>& body_keys() {
  using B = BodySpec;
  static const std::vector<DeckKey<B>> keys = {
      {"name", &B::name, "unique among the bodies", {}, {}, "", "`body<k>`"},
      needed(custom_key<B>("mesh",
                           "as [`mesh`](#mesh-required), with `transform`: a `box` or tetrahedral `file` (`.mesh`, "
                           "`.msh`); a cloth's `sheet`, `.obj` file or `.mesh`/`.msh` file with `surface: cloth`; "
                           "`strands` (alone, or with its box or file: tied where an end lies on one of their "
                           "vertices) or a Medit file with `edges: strands`",
                           "the body's tets, cloth triangles or strand segments; a body's mesh is not a partition file "
                           "(a deck error): the bodies' one partition file is `partition`, below",
                           "")),
      custom_key<B>("material", "as [`material`](#material-required-when-the-mesh-has-tetrahedra)",
                    "the material of the body's tets (a deck error for a mesh without them)",
                    "required if the mesh has tets"),
      custom_key<B>("cloth", "as [`cloth`](#cloth-required-when-the-mesh-is-a-cloth)",
                    "the body's cloth model, stiffness, bending and areal density (a deck error for a mesh that is "
                    "no cloth)",
                    "required for a cloth"),
      custom_key<B>("strand_material", "as [`strand_material`](#strand_material-required-when-the-mesh-has-strands)",
                    "the material of the body's strand segments (a deck error for a mesh without strands)",
                    "required if the mesh has strands"),
      {"velocity", &B::velocity, "every free vertex's velocity at frame 0 (not with `integrator: static`)"},
      custom_key<B>("fixed", "as [`fixed`](#fixed)",
                    "regions of this body only: a box selects the body's vertices in it (coordinates after the body's "
                    "transform), none of the others'; listed after the deck's own `fixed`",
                    "none"),
      custom_key<B>("attachments", "as [`attachments`](#attachments)",
                    "soft attachments of this body only, selecting as its `fixed` does (a box with no vertex of the "
                    "body is an error naming `bodies[k].attachments[j].box`); listed after the deck's own "
                    "`attachments`",
                    "none"),
  };
  return keys;
}

// The materials of the tets of a scene of bodies: one per body with a material, in the list's
// order, and per body the index of its material there (-1: none); a tet's body is its tag.
struct BodyMaterials {
  std::vector<MaterialSpec> materials;
  std::vector<int32_t> of_body;
};
inline BodyMaterials body_materials(const std::vector<BodySpec>& bodies) {
  BodyMaterials m;
  for (const BodySpec& b : bodies) {
    m.of_body.push_back(b.has_material ? (int32_t)m.materials.size() : -1);
    if (b.has_material) m.materials.push_back(b.material);
  }
  return m;
}

struct SceneSpec {
  std::string path;                      // the deck file (input errors name it)
  std::string name;                      // deck file name without directory and extension
  MeshSpec mesh;                         // the one body's mesh (without bodies)
  std::vector<BodySpec> bodies;          // several bodies (then mesh is unused and material is the first solid body's)
  std::string partition_file;            // with bodies: the partition file of the joined bodies (deck partition:;
                                         // "": rank 0 reads and joins them), checked when the scene is loaded
  int partition_line = 0;                // its deck line
  MaterialSpec material;                 // the default material (of the tets)
  bool has_material = false;             // material given (needed iff the mesh has tets)
  StrandMaterial strand_material;        // of the strand segments (if the mesh has any)
  ClothSpec cloth;                       // of the cloth triangles (if the mesh is a cloth)
  std::vector<MaterialRegion> regions;   // per-region materials
  std::vector<BoxRegion> fixed;
  std::vector<ColliderSpec> colliders;   // obstacles (none: no contact code at all)
  ContactSpec contact;                   // how contact is modelled (if there are colliders)
  std::vector<AttachmentSpec> attachments;  // soft attachments (springs to moving targets)
  std::vector<LoadSpec> loads;           // tractions, pressures, forces (none: no load code at all)
  std::vector<CutSpec> cuts;             // scripted cuts (none: no topology code at all; docs/topology.md)
  int cuts_line = 0;                     // the deck line of cuts:
  InitialSpec initial;
  std::array<double, 3> gravity{0, -9.81, 0};
  TimeSpec time;
  // The face_tag of each fixed region and load that gives one, in the deck's order: its key
  // ("loads[2].face_tag"), deck line and tag.
  struct NamedFaceTag {
    std::string key;
    int line;
    int32_t tag;
  };
  std::vector<NamedFaceTag> named_face_tags() const {
    std::vector<NamedFaceTag> named;
    for (size_t k = 0; k < fixed.size(); ++k)
      if (fixed[k].has_face_tag) named.push_back({region_key(fixed, k, "fixed") + ".face_tag", fixed[k].face_tag_line, fixed[k].face_tag});
    for (size_t k = 0; k < loads.size(); ++k)
      if (loads[k].has_face_tag) named.push_back({"loads[" + std::to_string(k) + "].face_tag", loads[k].face_tag_line, loads[k].face_tag});
    return named;
  }
  // Their tags, ascending, each once (empty: the mesh file's triangles are not read).
  std::vector<int32_t> face_tags() const {
    std::vector<int32_t> tags;
    for (const NamedFaceTag& n : named_face_tags()) tags.push_back(n.tag);
    std::sort(tags.begin(), tags.end());
    tags.erase(std::unique(tags.begin(), tags.end()), tags.end());
    return tags;
  }
};

// A free scene: nothing acts on its bodies but their own forces (elastic, self-contact): no fixed
// regions, attachments, colliders, gravity or damping. The time step conserves its linear
// momentum (every integrator; not its angular momentum: implicit Euler does not), so what a frame
// changes of it is the solve's error (summary.json's momentum_change).
inline bool free_scene(const SceneSpec& s) {
  return s.fixed.empty() && s.attachments.empty() && s.colliders.empty() && s.loads.empty() && s.gravity == std::array<double, 3>{0, 0, 0} &&
         s.time.damping == 0;
}

// The deck's gravity: (params/deck_keys.hpp), a section that is one value: its one key is the section.
inline const std::vector<DeckKey<SceneSpec>>& gravity_keys() {
  static const std::vector<DeckKey<SceneSpec>> keys = {
      {"gravity", &SceneSpec::gravity, "the acceleration of every vertex, in the units of the deck (m/s² in SI)"},
  };
  return keys;
}

}  // namespace hyperqn
