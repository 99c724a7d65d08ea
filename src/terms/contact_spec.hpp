// How the deck says contact is modelled (its contact: section), the contact term's parameters
// (terms/contact.hpp), with its keys declared beside them.
#pragma once
#include <string>
#include <vector>

#include "params/deck_keys.hpp"

namespace hyperqn {

// The deck's contact: section (its keys, ranges and defaults: contact_keys() below); 0 means "the
// default" for the scene-dependent values.
enum class ContactModel { penalty, barrier };
inline const std::vector<std::string> kContactModelNames = {"penalty", "barrier"};  // in the enum's order

struct ContactSpec {
  ContactModel model = ContactModel::penalty;
  double distance = 0;              // activation distance d; 0: 1e-2 of the rest bounding-box diagonal
  double stiffness = 1e3;           // force at full penetration of d, in vertex weights
  double friction_velocity = 0;     // eps: sliding below eps is sticking; 0: 1e-2 diagonals per second
  bool self = false;                // self-contact: the surfaces of all bodies and cloths against each other
  double self_friction = 0;         // Coulomb coefficient mu between surfaces in self-contact
  double self_distance = 0;         // activation distance between surfaces in self-contact; 0: distance
  int line = 0;                     // deck line of the section
  int distance_line = 0;            // and of distance, when given
  int self_line = 0;                // and of self, when given
  int self_distance_line = 0;       // and of self_distance, when given
  // Not a deck key: the key `distance` came from, for messages (self_contact_spec sets it).
  const char* distance_key = "contact.distance";
  // Not a deck key: self-contact treats surface vertices of one body at the same rest position as
  // one vertex (a crack's sides that could not open, mesh/separation.hpp CrackOpening); set in
  // scenes with cuts.
  bool joined_twins = false;
};
// The defaults above, resolved for a body of rest bounding-box diagonal `diagonal`.
ContactSpec resolved_contact(ContactSpec spec, double diagonal);
// The same for self-contact: its distance is self_distance where the deck gives it (distance_line and
// distance_key then name that key).
ContactSpec self_contact_spec(ContactSpec spec, double diagonal);

// The deck's contact: keys (params/deck_keys.hpp). Its defaults of 0 are resolved for the scene
// (resolved_contact).
inline const std::vector<DeckKey<ContactSpec>>& contact_keys() {
  using C = ContactSpec;
  static const std::vector<DeckKey<C>> keys = {
      enum_key<C>("model", &C::model, kContactModelNames,
                  "`penalty`: a one-sided cubic penalty on the distance to the obstacle; `barrier`: IPC's log barrier, "
                  "infinite at the obstacle, with every step bounded by continuous collision detection, so no vertex "
                  "ever reaches an obstacle (measured against each other in [contact.md](contact.md))"),
      {"distance", &C::distance,
       "activation distance d: a vertex closer than d to an obstacle is pushed back; at most the rest bounding-box "
       "diagonal (after `mesh.transform`: a layer thicker than the body is an error naming the deck line). Resting "
       "bodies float about d above the obstacle (a vertex sinks d·√(f/stiffness) into this layer under f times its "
       "own weight); smaller values give a thinner gap and more iterations ([contact.md](contact.md#defaults))",
       above(0, "a length; omit it for 1e-2 of the body's rest diagonal"), {}, "",
       "1e-2 × the rest bounding-box diagonal"},
      {"stiffness", &C::stiffness,
       "the force on a vertex that penetrates the whole activation layer (the barrier: half of it), in multiples of "
       "its own weight m g₀ (g₀ = 9.80665 m/s²), whatever the units, masses or time step",
       between(1, 1e12, "force at full penetration, in vertex weights")},
      {"friction_velocity", &C::friction_velocity,
       "ε: tangential speeds below ε count as sticking (the friction force grows from 0 at rest to μ N at ε). "
       "Smaller values creep less on a slope and take more iterations",
       above(0, "a speed; omit it for 1e-2 rest diagonals per second"), {}, "", "1e-2 rest diagonals per second"},
      {"self", &C::self,
       "`true`: self-contact, the surfaces (tets' boundary faces, cloth triangles) of all bodies and cloths against "
       "each other and themselves, vertex against triangle and edge against edge, with the same `model`, `distance` "
       "and `stiffness` (a cloth's `thickness` adds to the distance its pairs keep; surfaces that cross at frame 0 "
       "are an input error; friction between them: `self_friction`; [self-contact.md](self-contact.md)). A deck "
       "may then have no colliders"},
      {"self_friction", &C::self_friction,
       "Coulomb coefficient μ between surfaces in self-contact (`self: true`), lagged and smoothed like the "
       "colliders' `friction` (with the same `friction_velocity`); each collider keeps its own `friction`",
       between(0, 100, "a Coulomb coefficient")},
      {"self_distance", &C::self_distance,
       "activation distance between surfaces in self-contact (`self: true`), instead of `distance`, which then "
       "holds for the colliders alone: a mesh whose surface comes close to itself at rest needs a self-contact "
       "distance below that gap, while its contact with the ground need not be that thin (a thin layer takes more "
       "iterations; [self-contact.md](self-contact.md#two-distances)); at most the rest bounding-box diagonal",
       above(0, "a length; omit it for `distance`"), {}, "", "`distance`"},
  };
  return keys;
}

}  // namespace hyperqn
