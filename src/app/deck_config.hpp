// The effective configuration: every setting of a deck as the run uses it, with where its value
// came from. `hyperqn config DECK` prints it, and a run writes it to OUTDIR/config.yaml
// (docs/deck-run.md#the-effective-configuration, docs/outputs.md).
#pragma once
#include <string>

#include "app/deck.hpp"
#include "app/run_options.hpp"

namespace hyperqn {

// One line per setting, `key: value  # source`, the key dotted as in error messages
// ("bodies[0].material.mu") and the value in YAML (numbers at full double precision); the source
// is `deck line N`, `default`, `rule: <why>` (a value another setting implies: contact's solver
// defaults, mu and lambda from Young's modulus and Poisson's ratio), or `command line` (a PETSc or
// -hyperqn_* option given there, and -o). Every declared key that applies to the deck is listed
// (a key of another model, type or map is not), then the hyperqn options, the PETSc options, and
// last any other key the deck gives (read by its section's own reader), as written. outdir: the
// run's output directory. Reads the PETSc options database: collective, like read_run_options.
std::string effective_config(const Deck& deck, const RunOptions& options, const std::string& outdir);

}  // namespace hyperqn
