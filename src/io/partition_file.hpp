// The partition file (`hyperqn partition DECK -n N -o FILE.h5`): a mesh already cut into N pieces
// (mesh/mesh_piece.hpp), so that a run reads its piece directly and no rank ever holds the whole
// mesh (docs/performance.md#partition-files).
//
// One HDF5 file (io/hdf5_file.hpp: written in memory then atomically, every dataset with
// Fletcher32 checksums). For each array NAME of piece_arrays, the pieces' rows one after the
// other in a (rows, width) table NAME (coords 3 columns, tets 4, segments 2, triangles 3,
// hinges 4, the others 1), and NAME_offsets (parts + 1, 1): part p's rows are
// [offsets[p], offsets[p + 1]). Beside them 1 x 1 int64 tables: format_version, parts,
// global_vertices (the whole mesh's vertices), total_tets, total_segments, total_triangles,
// total_hinges, dropped_vertices and reoriented_tets (what cleaning the mesh changed);
// part_checksums (parts, 1): a checksum of each piece's arrays, which reading checks; and the
// texts format ("hyperqn partition file") and source (the deck and mesh it was made from).
// A file of a scene of bodies (deck bodies:) also has the 1 x 1 tables bodies (their count; every
// element's tag is its body) and bodies_hash (mesh_sources_hash of the bodies' meshes), which a run
// checks against its deck; a file without them holds one mesh.
#pragma once
#include <mpi.h>

#include <cstdint>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"
#include "mesh/mesh_piece.hpp"
#include "mesh/mesh_spec.hpp"

namespace hyperqn {

constexpr int kPartitionFileVersion = 1;

// What a scene of bodies' file was made from: the number of bodies (0: one mesh) and the hash of
// their meshes as the deck describes them (mesh_sources_hash).
struct BodiesStamp {
  int64_t count = 0;
  uint64_t hash = 0;
};

// Cuts `serial` (cleaned: read_serial_mesh, or clean_mesh) into nparts with pieces_of_serial_mesh
// and writes every piece to path (replacing it whole; nothing is written on failure). `source`:
// what the mesh was made from; `repaired`: what cleaning it changed; `bodies`: the bodies joined in
// it, if any (their indices are the elements' tags). Throws std::runtime_error "cannot write PATH: <reason>".
void write_partition_file(const std::string& path, const TetMesh& serial, int nparts, const std::string& source,
                          const CleanReport& repaired = CleanReport(), const BodiesStamp& bodies = BodiesStamp());

// The hash a file of bodies is stamped with: FNV-1a over each mesh's description in order (box or
// sheet and its size and cells, transform, strands, surface: cloth, edges: strands) and the bytes
// of its file (not its path: a moved deck keeps its file). Reads every file whole, in blocks;
// throws InputError naming a file it cannot read.
uint64_t mesh_sources_hash(const std::vector<MeshSpec>& meshes);

// What a partition file holds, from its header and offsets (all of them checked: counts, offsets
// monotone and within each table, tables of one piece consistent in size), without its pieces.
struct PartitionFileInfo {
  int version = 0;
  int parts = 0;
  int64_t vertices = 0, tets = 0, segments = 0, triangles = 0, hinges = 0;  // of the whole mesh
  CleanReport repaired;  // what cleaning the mesh changed when the file was written
  std::string source;    // what it was made from
  BodiesStamp bodies;    // the bodies joined in it (count 0: one mesh)
};
// Throws InputError naming the file if it is missing, unreadable, not a partition file, of
// another format version, or inconsistent.
PartitionFileInfo read_partition_info(const std::string& path);

// Collective over comm: each rank opens the file read-only and reads only the rows of its own
// parts. With as many parts as ranks, rank r gets part r, the same piece pieces_of_serial_mesh
// gave bit for bit. With fewer ranks (M < P), rank r takes the parts [r P / M, (r + 1) P / M)
// merged (merge_pieces). With more, part p goes to the ranks [ceil(p M / P), ceil((p + 1) M / P)):
// the first of them reads it and cuts it by METIS for the group (share_piece). No rank reads
// more than its parts, or one part.
// Everything read is checked (the checksum of each part, offsets, sizes, vertex indices within
// the piece, vertex and element numbers within the whole mesh's counts, in a file of bodies each
// element's tag a body); any error is the same InputError naming the file on every rank.
MeshPiece read_partition_piece(MPI_Comm comm, const std::string& path);

// The checksum part_checksums holds: FNV-1a over every array of the piece (its name, length and
// bytes, in piece_arrays' order).
uint64_t piece_checksum(MeshPiece& piece);

}  // namespace hyperqn
