// hyperqn partition DECK -n N -o FILE.h5: the deck's mesh (or its bodies, joined), read and cleaned
// as a run would (read_serial_mesh), cut into N pieces and written as a partition file
// (io/partition_file.hpp), which a deck then names as mesh.file (or, for bodies, as partition:,
// and then -o may be left out). Rank 0 does the work; other ranks of the launch wait.
#pragma once
#include <mpi.h>

#include <string>

#include "app/deck.hpp"

namespace hyperqn {

// Collective. Throws InputError (on every rank alike) for a deck whose mesh is itself a partition
// file, no output (output "" and no partition: in the deck), more parts than the mesh has
// elements, or a failure to write (nothing is written then);
// prints one line (the file, parts, vertices, elements, bytes) when done.
void run_partition(MPI_Comm comm, const Deck& deck, int parts, const std::string& output);

}  // namespace hyperqn
