// A material as a scene describes it: the model and its parameters, its mass, and its weight in
// L (MaterialSpec, declared beside the material registry that names its keys:
// materials/material_factory.hpp); and the materials of strand segments and of cloth.
#pragma once
#include <array>
#include <string>
#include <vector>

#include "params/deck_keys.hpp"
#include "materials/cloth_models.hpp"
#include "materials/material_factory.hpp"
#include "materials/yielding_spring.hpp"

namespace hyperqn {

// The material of all strand segments: a segment of rest length L stores
// E = EA/(2L) (l - L)^2 = L/2 EA (l/L - 1)^2 and carries linear_density * L of mass.
struct StrandMaterial {
  double axial_stiffness = 0;        // EA: force per unit strain (N)
  double linear_density = 0;         // mass per unit rest length (kg/m)
  double laplacian_weight = 0;       // 0: EA builds L (exact); > 0: this value in its place
  SpringYield yield;                 // the segments' rest lengths flow past it (strain 0: elastic)
  double snap_strain = 0;            // a segment snaps past this strain l/L - 1 (0: never)
  int snap_resolve = 0;              // a step whose converged state snaps a segment is solved again, up to this many times
};

// The deck's strand_material: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<StrandMaterial>>& strand_material_keys() {
  using S = StrandMaterial;
  static const std::vector<DeckKey<S>> keys = {
      {"axial_stiffness", &S::axial_stiffness,
       "EA, the force per unit strain: a segment of rest length L stores E = EA/(2L) (l − L)²", above(0), {}, "N", "",
       nullptr, nullptr, "", true},
      {"linear_density", &S::linear_density, "mass per unit rest length, lumped half to each end of a segment",
       above(0), {}, "kg/m", "", nullptr, nullptr, "", true},
      {"laplacian_weight", &S::laplacian_weight,
       "the EA used to build L (each segment adds weight/L). Omit it for the strands' own, exact weight.",
       above(0, "omit the key for the strands' own weight, axial_stiffness"), {}, "N", "`axial_stiffness`"},
      {"yield_strain", Field<S, double>([](S& s) -> double& { return s.yield.strain; }),
       "the segments yield: past this elastic strain (|ε − ε_p| with ε = l/L − 1 and L_p = L(1 + ε_p)), a segment's rest length L_p flows, so a stretched "
       "strand keeps part of its stretch ([yielding-springs.md](yielding-springs.md))",
       above(0, "an elastic strain, e.g. 0.01; omit the key for elastic strands"), {}, "", "none (elastic)"},
      {"hardening", Field<S, double>([](S& s) -> double& { return s.yield.hardening; }),
       "with `yield_strain`: the yield strain's growth per unit of accumulated plastic strain (H/E; 0: perfectly "
       "plastic)",
       at_least(0)},
      map_key<S>("snap", "the segments snap: after a step, a segment stretched past the strain lets go of the rest of "
                         "the strand at both ends ([snapping.md](snapping.md))",
                 "none (never snaps)"),
      needed(DeckKey<S>{"snap.strain", &S::snap_strain,
                        "a segment whose strain l/L − 1 (L its rest length) exceeds this after a step snaps",
                        above(0, "a strain, e.g. 0.2")}),
      {"snap.resolve", &S::snap_resolve,
       "how many times a step whose converged state snaps a segment is solved again, from its start with that segment "
       "snapped, until none is over (one segment each time; 0: it snaps at the next step's start; the scene takes its "
       "strands' largest)",
       at_least(0)},
  };
  return keys;
}

// The material of a cloth surface (docs/cloth.md): in-plane stretching by springs on the edges
// (Liu et al. 2013) or a triangle-FEM membrane, bending across interior edges, and areal density.
enum class ClothModel { mass_spring, membrane };
// The deck's words, in the enums' order (materials/cloth_models.hpp).
inline const std::vector<std::string> kClothModelNames = {"mass-spring", "membrane"};
inline const std::vector<std::string> kMembraneMaterialNames = {"stvk", "corotated", "neohookean"};
inline const std::vector<std::string> kBendingModelNames = {"quadratic", "dihedral", "springs", "none"};

struct ClothSpec {
  ClothModel model = ClothModel::mass_spring;
  double stretch_stiffness = 0;      // mass-spring: k of the spring on every edge (N/m)
  membrane::Model material = membrane::Model::stvk;
  double youngs_modulus = 0, poisson_ratio = 0;  // membrane: as the deck gives them
  double mu = 0, lambda = 0;         // membrane: 2-D (plane-stress) Lame parameters (N/m), from E and nu
  BendingModel bending = BendingModel::none;
  double bending_stiffness = 0;      // quadratic, dihedral: a bending modulus (N m); springs: k (N/m)
  double areal_density = 0;          // mass per unit rest area (kg/m^2)
  SpringYield yield;                 // mass-spring: the edge springs' rest lengths flow past it
  SpringYield bending_yield;         // springs bending: the bending springs' rest lengths flow past it
  double thickness = 0;              // in self-contact: its mid-surfaces keep this much farther apart
  int thickness_line = 0;            // deck line of thickness, when given
  double tear_strain = 0;            // an interior edge tears past this strain across it (0: never)
  int tear_resolve = 0;              // a step whose converged state tears an edge is solved again, up to this many times
};

// The deck's cloth: keys (params/deck_keys.hpp).
inline const std::vector<DeckKey<ClothSpec>>& cloth_keys() {
  using C = ClothSpec;
  static const std::vector<DeckKey<C>> keys = {
      needed(enum_key<C>("model", &C::model, kClothModelNames,
                         "in-plane elasticity: a spring on every edge (Liu et al. 2013), or a triangle-FEM membrane")),
      only_with(DeckKey<C>{"stretch_stiffness", &C::stretch_stiffness, "k of every edge spring: E = k/2 (l − L)²",
                           above(0), {}, "N/m"},
                "model", {"mass-spring"}, true),
      only_with(DeckKey<C>{"yield_strain", Field<C, double>([](C& c) -> double& { return c.yield.strain; }),
                           "the edge springs yield: past this elastic strain (|ε − ε_p| with ε = l/L − 1 and L_p = L(1 + ε_p)), a spring's rest length L_p "
                           "flows ([yielding-springs.md](yielding-springs.md))",
                           above(0, "an elastic strain, e.g. 0.01; omit the key for elastic springs"), {}, "",
                           "none (elastic)"},
                "model", {"mass-spring"}, false),
      only_with(DeckKey<C>{"hardening", Field<C, double>([](C& c) -> double& { return c.yield.hardening; }),
                           "with `yield_strain`: the yield strain's growth per unit of accumulated plastic strain (H/k; "
                           "0: perfectly plastic)",
                           at_least(0)},
                "model", {"mass-spring"}, false),
      only_with(enum_key<C>("material", &C::material, kMembraneMaterialNames,
                            "the energy density of the 3×2 deformation gradient"),
                "model", {"membrane"}, false),
      only_with(DeckKey<C>{"youngs_modulus", &C::youngs_modulus,
                           "the sheet's stretching modulus E·t: energy per unit rest area",
                           above(0, "the sheet's stretching modulus, N/m")},
                "model", {"membrane"}, true),
      only_with(DeckKey<C>{"poisson_ratio", &C::poisson_ratio,
                           "with `youngs_modulus`, the plane-stress Lamé constants μ = E/(2(1+ν)), λ = Eν/(1−ν²)",
                           {-1, 0.5, true, true}},
                "model", {"membrane"}, true),
      map_key<C>("bending", "bending across every interior edge", "`model: none`"),
      needed(enum_key<C>("bending.model", &C::bending, kBendingModelNames,
                         "Bergou et al. 2006 (flat rest shapes), Grinspun et al. 2003 (large folds, curved rest "
                         "shapes), a spring between the two vertices opposite the edge (Liu et al. 2013), or none")),
      only_with(DeckKey<C>{"bending.stiffness", &C::bending_stiffness,
                           "quadratic, dihedral: a bending modulus (N·m); springs: k (N/m)", above(0)},
                "model", {"quadratic", "dihedral", "springs"}, true),
      only_with(DeckKey<C>{"bending.yield_strain", Field<C, double>([](C& c) -> double& { return c.bending_yield.strain; }),
                           "the bending springs yield: past this elastic strain a spring's rest length flows, so a fold "
                           "keeps a crease ([yielding-springs.md](yielding-springs.md))",
                           above(0, "an elastic strain, e.g. 0.05; omit the key for elastic bending"), {}, "",
                           "none (elastic)"},
                "model", {"springs"}, false),
      only_with(DeckKey<C>{"bending.hardening", Field<C, double>([](C& c) -> double& { return c.bending_yield.hardening; }),
                           "with `bending.yield_strain`: the yield strain's growth per unit of accumulated plastic "
                           "strain (H/k; 0: perfectly plastic)",
                           at_least(0)},
                "model", {"springs"}, false),
      needed(DeckKey<C>{"areal_density", &C::areal_density,
                        "mass per unit rest area, lumped a third to each vertex of a triangle", above(0, "kg/m^2")}),
      {"thickness", &C::thickness,
       "in self-contact (`contact.self: true`, a deck error without it), the cloth's thickness t: each side of its "
       "mid-surface reaches t/2, so a pair of primitives measures its distance less half the thickness of each "
       "(two layers of the cloth rest about t + d apart, the cloth on a solid about t/2 + d, d the self-contact "
       "distance: `contact.self_distance`, else `distance`); the continuous collision test keeps that much apart. "
       "t + d must stay "
       "below the mesh's spacing at rest ([self-contact.md](self-contact.md#cloth-thickness)); a cloth that tears "
       "needs t below a tenth of its least triangle height ([snapping.md](snapping.md#tearing-cloth))",
       at_least(0, "a length")},
      map_key<C>("tear", "the cloth tears: after a step, the interior edge most stretched across past the strain "
                         "separates its two triangles ([snapping.md](snapping.md#tearing-cloth))",
                 "none (never tears)"),
      needed(DeckKey<C>{"tear.strain", &C::tear_strain,
                        "an interior edge whose strain across (its two triangles' mean stretch perpendicular to it, "
                        "less 1) exceeds this after a step tears",
                        above(0, "a strain, e.g. 0.2")}),
      {"tear.resolve", &C::tear_resolve,
       "how many times a step whose converged state tears an edge is solved again, from its start with that edge "
       "torn, until none is over (one edge each time; 0: it tears at the next step's start, and a crack grows by one "
       "edge per step; the scene takes its cloths' largest)",
       at_least(0)},
  };
  return keys;
}

}  // namespace hyperqn
