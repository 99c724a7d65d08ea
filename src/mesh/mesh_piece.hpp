// One rank's piece of the mesh before the scene is built on it: the elements this rank will hold
// and every vertex they use, numbered locally. No rank holds the whole mesh once pieces exist:
// they come from rank 0's serial mesh cut by METIS (pieces_of_serial_mesh, sent one by one), from
// a partition file (io/partition_file.hpp), or are generated on each rank (box_piece).
//
// The order of a piece is a rule, not a history, so the same partition always gives the same
// distributed mesh bitwise, whichever way its pieces arrived: elements by kind (tets, segments,
// triangles, hinges), each kind in the order of the whole mesh; vertices by their number in the
// whole mesh. distribute_mesh (mesh/distributed_mesh.hpp) builds the DMPlex from it.
#pragma once
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "mesh/mesh.hpp"

namespace hyperqn {

struct MeshPiece {
  // Local elements (vertex indices into the local vertices), local vertices (coords, vertex_ids:
  // their ids in the input file), and the cloth's hinges and carried edges: a TetMesh, so that
  // what works on a mesh (regions, transforms) works on a piece.
  TetMesh mesh;
  std::vector<int64_t> vertex_numbers;   // per local vertex: its number in the whole mesh, ascending
  std::vector<int64_t> element_numbers;  // per local tet, then segment, then triangle: its index
                                         // among the whole mesh's elements of its kind
  int64_t global_vertices = 0;           // vertices of the whole mesh
  // 3 per local vertex: its rest position before any crack opened (a copy: its original's), from
  // which the tets' masses come (mesh/separation.hpp CrackOpening); empty until a crack opens on
  // this piece (then the same as mesh.coords). Made by the cuts a restart replays, so not packed.
  std::vector<double> unopened;
};

// Every array of a piece with a name (the partition file's dataset names; MPI packing): the one
// list of what a piece carries.
struct PieceArrays {
  std::vector<std::pair<const char*, std::vector<double>*>> doubles;
  std::vector<std::pair<const char*, std::vector<int32_t>*>> ints;
  std::vector<std::pair<const char*, std::vector<int64_t>*>> longs;
  std::vector<std::pair<const char*, std::vector<uint8_t>*>> bytes;
};
PieceArrays piece_arrays(MeshPiece& piece);

// fn(name, vector) for every array of a piece, of whatever element type, in piece_arrays' order.
template <typename Fn>
void for_each_array(MeshPiece& piece, Fn&& fn) {
  PieceArrays a = piece_arrays(piece);
  for (auto& [name, v] : a.doubles) fn(std::string(name), *v);
  for (auto& [name, v] : a.ints) fn(std::string(name), *v);
  for (auto& [name, v] : a.longs) fn(std::string(name), *v);
  for (auto& [name, v] : a.bytes) fn(std::string(name), *v);
}

// The pieces of a serial mesh cut into nparts by METIS (nparts = 1: the mesh itself), handed to
// fn one at a time, part 0 first, so that at most one piece exists beside the mesh. The mesh is
// cleaned (clean_mesh: hinges and carried edges filled).
void pieces_of_serial_mesh(const TetMesh& serial, int nparts, const std::function<void(int part, MeshPiece&)>& fn);

// Part `part` of nparts of the box generate_box(size, cells) makes, cut into a grid of blocks of
// cells (the grid with the smallest interface; box_block_grid), generated directly: the same
// vertices, tets and numbers as generate_box's. An empty array if no grid fits (more parts than
// a box of these cells can split into): the box is then cut by METIS.
std::array<int, 3> box_block_grid(const std::array<int, 3>& cells, int nparts);
MeshPiece box_piece(const std::array<double, 3>& size, const std::array<int, 3>& cells, int part, int nparts);

// Part `part` of nparts of the cloth sheet generate_sheet(size, cells) makes, cut into a grid of
// blocks of cells (box_block_grid of {cells[0], cells[1], 1}): its triangles, the hinges whose
// first triangle is in the block (with the vertices they reach across the block's edge), and
// the carried edges, all as clean_mesh finds them on the whole sheet.
MeshPiece sheet_piece(const std::array<double, 2>& size, const std::array<int, 2>& cells, int part, int nparts);

// MPI: the piece as one byte buffer and back.
std::vector<char> pack_piece(MeshPiece& piece);
MeshPiece unpack_piece(const std::vector<char>& buffer);

// The mesh's fingerprint, summed over pieces: per element (tet, segment, triangle) two 64-bit
// hashes of its kind, number, tag and its vertices' ids and coordinates. The sums over all ranks'
// pieces (modulo 2^64) do not depend on how the mesh is cut, so a checkpoint's mesh is recognised
// at any rank count without any rank holding the mesh.
std::array<uint64_t, 2> piece_hash_sums(const MeshPiece& piece);

// Pieces merged into one (a rank that takes several parts of a partition file): elements of
// each kind in the pieces' order, vertices merged by number.
MeshPiece merge_pieces(std::vector<MeshPiece>& pieces);

// A piece cut into nparts by METIS (a part of a partition file shared by several ranks), each in
// the order of the piece rule, with the whole mesh's numbers; handed to fn one at a time.
void split_piece(const MeshPiece& piece, int nparts, const std::function<void(int part, MeshPiece&)>& fn);

}  // namespace hyperqn
