// Every deck section declared with io/deck_keys.hpp, in the deck's order: what `hyperqn
// --help-deck` prints, `hyperqn registry` exports and scripts/deck_tables.py turns into
// docs/decks.md's tables. The other sections (mesh, bodies, material, regions, fixed,
// attachments, colliders, contact, initial, gravity, strand_material, cloth, study, petsc) are
// read by their own functions in app/deck.cpp and documented by hand.
#include "app/deck.hpp"

namespace hyperqn {

std::vector<KeyInfo> declared_deck_keys() {
  std::vector<KeyInfo> all;
  for (const std::vector<KeyInfo>& section :
       {key_infos("time", time_keys()), key_infos("solver", solver_keys()), key_infos("output", output_keys()),
        key_infos("checkpoint", checkpoint_keys())})
    all.insert(all.end(), section.begin(), section.end());
  return all;
}

}  // namespace hyperqn
