// The kinds of load a deck's loads: list may name (terms/load_kind.hpp), their keys and their terms.
#pragma once
#include <memory>
#include <vector>

#include "terms/load_kind.hpp"

namespace hyperqn {

// Every kind, in the order the docs list them.
const std::vector<LoadKind>& load_kinds();
const LoadKind* find_load_kind(const std::string& type);

// The keys of one entry of loads: (params/deck_keys.hpp): type, the region's, then every kind's own
// (each a key of its type only).
const std::vector<DeckKey<LoadSpec>>& load_keys();

// The deck's loads as terms, in the deck's order (collective).
std::vector<std::unique_ptr<EnergyTerm>> load_terms(const DistributedMesh& mesh, const std::vector<LoadSpec>& loads);

}  // namespace hyperqn
