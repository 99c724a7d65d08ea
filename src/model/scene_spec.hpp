// A scene as the deck describes it: mesh, materials, regions, initial state, gravity and time
// stepping. The deck (app/deck.hpp) is a scene plus how to run it (solver, output, study); the
// model builds from this alone.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "geometry/collider.hpp"
#include "io/deck_keys.hpp"
#include "mesh/mesh_spec.hpp"
#include "model/material_spec.hpp"
#include "model/regions.hpp"
#include "model/time_integrator.hpp"
#include "terms/contact_spec.hpp"

namespace hyperqn {

struct TimeSpec {
  double dt = 1.0 / 30.0;
  int frames = 100;
  double damping = 0;                // v <- (1 - damping) v after each step
  TimeIntegrator integrator = TimeIntegrator::implicit_euler;
};

// The deck's time: keys (io/deck_keys.hpp).
inline const std::vector<DeckKey<TimeSpec>>& time_keys() {
  static const std::vector<DeckKey<TimeSpec>> keys = {
      {"dt", &TimeSpec::dt, "time step (one step per frame)", above(0), {}, "s", "1/30"},
      {"frames", &TimeSpec::frames, "number of time steps", between(1, 1e8)},
      {"damping", &TimeSpec::damping, "after each step, v ← (1 − damping) v", {0, 1, false, true}},
      {"integrator", std::monostate{},
       "the time integrator ([method.md](method.md#time-integrators)): `bdf2` is second order and L-stable, loses far "
       "less energy than implicit Euler and fails no stability case; `implicit-midpoint` is second order and keeps the "
       "energy of vibrations that implicit Euler damps out; a step whose end would invert or blow up a tet is "
       "completed by implicit Euler instead (`euler_completed_steps` in `summary.json`), so it fails no stability "
       "case, but it is best in calm scenes (7 of the 21 cases degraded, Euler 5); not with `colliders` (a deck error)",
       {}, integrator_names(), "", "",
       [](TimeSpec& t, const std::string& name) { t.integrator = integrator_named(name)->kind; },
       [](const TimeSpec& t) { return std::string(integrator_info(t.integrator).name); }},
  };
  return keys;
}

// An extreme initial state (positions at frame 0; the rest shape stays the mesh). c is the
// centre of the rest bounding box; fixed vertices stay where they are.
struct InitialSpec {
  std::string kind;                  // "" (rest) | squash | collapse | random | invert
  int axis = 1;                      // squash, invert: the coordinate axis (0, 1, 2)
  double factor = 0;                 // squash: x_A = c_A + factor (X_A - c_A)
  long seed = 1;                     // random: uniform in the rest bounding box, per vertex id
};

// One body of a scene of several (deck bodies:): its own tet mesh (a box or a file, with its
// transform), material and initial velocity; its fixed regions are in SceneSpec::fixed with
// BoxRegion::body set. All bodies go into one mesh (vertex ids body by body), one factor, one solve.
struct BodySpec {
  std::string name;                      // bodies[k].name, default body<k>
  MeshSpec mesh;
  MaterialSpec material;
  std::array<double, 3> velocity{0, 0, 0};
  int line = 0;                          // deck line of bodies[k]
};

struct SceneSpec {
  std::string path;                      // the deck file (input errors name it)
  std::string name;                      // deck file name without directory and extension
  MeshSpec mesh;                         // the one body's mesh (without bodies)
  std::vector<BodySpec> bodies;          // several bodies (then mesh is unused and material is bodies[0]'s)
  MaterialSpec material;                 // the default material (of the tets)
  bool has_material = false;             // material given (needed iff the mesh has tets)
  StrandMaterial strand_material;        // of the strand segments (if the mesh has any)
  ClothSpec cloth;                       // of the cloth triangles (if the mesh is a cloth)
  std::vector<MaterialRegion> regions;   // per-region materials
  std::vector<BoxRegion> fixed;
  std::vector<ColliderSpec> colliders;   // obstacles (none: no contact code at all)
  ContactSpec contact;                   // how contact is modelled (if there are colliders)
  std::vector<AttachmentSpec> attachments;  // soft attachments (springs to moving targets)
  InitialSpec initial;
  std::array<double, 3> gravity{0, -9.81, 0};
  TimeSpec time;
};

}  // namespace hyperqn
