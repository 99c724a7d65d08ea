#include "mesh/distributed_mesh.hpp"

#include <petscsf.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <stdexcept>
#include <string>

namespace hyperqn {

// The kinds of cells, in the order a piece (and so the DMPlex) holds them.
enum CellKind : int32_t { kTetCell, kSegmentCell, kTriangleCell, kHingeCell };
constexpr int kCellSize[4] = {4, 2, 3, 4};

// What travels with each point of the DMPlex (cells first, then vertices), as flat arrays: the
// input element tag of a cell or the input vertex id of a vertex; the material of a tet, the
// carried edges of a triangle or the fixed flag of a vertex; the CellKind of a cell; the index of
// a tet, segment or triangle among the whole mesh's elements of its kind.
struct PointData {
  std::vector<int64_t> value;
  std::vector<int32_t> flag, kind;
  std::vector<int64_t> number;
};

// The DMPlex of a piece (non-interpolated: vertex dofs need no edges or faces): points are the
// piece's cells (tets, segments, triangles, hinges), then its vertices. A vertex that several
// pieces hold is owned by the lowest rank holding it; the point SF says so.
static PetscErrorCode create_piece_plex(MPI_Comm comm, const MeshPiece& piece, DM* dm) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  const TetMesh& m = piece.mesh;
  const std::vector<int32_t>* kinds[4] = {&m.tets, &m.segments, &m.triangles, &m.hinges};
  PetscInt nc = 0;
  for (int k = 0; k < 4; ++k) nc += (PetscInt)kinds[k]->size() / kCellSize[k];
  const PetscInt nv = (PetscInt)m.num_vertices();
  PetscInt num_points[2] = {nv, nc};  // by depth: vertices, cells
  std::vector<PetscInt> cone_size(nc + nv, 0), cones, orientations;
  cones.reserve(4 * size_t(nc));
  for (int k = 0, c = 0; k < 4; ++k) {
    for (size_t e = 0; e < kinds[k]->size() / kCellSize[k]; ++e) cone_size[c++] = kCellSize[k];
    for (int32_t v : *kinds[k]) cones.push_back(nc + v);  // vertex points come after the cells
  }
  orientations.assign(cones.size(), 0);
  PetscCall(DMCreate(comm, dm));
  PetscCall(DMSetType(*dm, DMPLEX));
  PetscCall(DMSetDimension(*dm, 3));
  PetscCall(DMPlexCreateFromDAG(*dm, 1, num_points, cone_size.data(), cones.data(), orientations.data(), m.coords.data()));
  // Every element is a cell of this mesh like a tet, so it is typed like one. PETSc orders the
  // points of a non-interpolated mesh by the dimension of their cell type where it moves them
  // (DMPlexDistribute in 3.18 failed with duplicate SF leaves when segments and triangles were
  // typed as 1- and 2-dimensional polytopes); nothing of hyperqn reads the cell type.
  DMLabel cell_type;
  PetscCall(DMPlexGetCellTypeLabel(*dm, &cell_type));
  for (PetscInt c = 0; c < nc; ++c) {
    PetscInt type;
    PetscCall(DMLabelGetValue(cell_type, c, &type));
    if (type == DM_POLYTOPE_TETRAHEDRON) continue;
    PetscCall(DMLabelClearValue(cell_type, c, type));
    PetscCall(DMLabelSetValue(cell_type, c, DM_POLYTOPE_TETRAHEDRON));
  }

  // Ownership of shared vertices, through the vertices' numbers in the whole mesh: every rank
  // holding a vertex meets the others at the rank that owns its number in an even layout.
  PetscLayout layout;
  PetscSF by_number;
  std::vector<PetscInt> numbers(piece.vertex_numbers.begin(), piece.vertex_numbers.end());
  PetscCall(PetscLayoutCreate(comm, &layout));
  PetscCall(PetscLayoutSetSize(layout, (PetscInt)piece.global_vertices));
  PetscCall(PetscLayoutSetUp(layout));
  PetscCall(PetscSFCreate(comm, &by_number));
  PetscCall(PetscSFSetGraphLayout(by_number, layout, nv, nullptr, PETSC_COPY_VALUES, numbers.data()));
  PetscCall(PetscLayoutDestroy(&layout));
  PetscInt nroots;
  PetscCall(PetscSFGetGraph(by_number, &nroots, nullptr, nullptr, nullptr));
  std::vector<PetscInt> root(nroots), owner(nv, rank), point(nv);
  auto meet = [&](MPI_Op op, PetscInt start, std::vector<PetscInt>& leaves) -> PetscErrorCode {
    PetscFunctionBeginUser;
    std::fill(root.begin(), root.end(), start);
    PetscCall(PetscSFReduceBegin(by_number, MPIU_INT, leaves.data(), root.data(), op));
    PetscCall(PetscSFReduceEnd(by_number, MPIU_INT, leaves.data(), root.data(), op));
    PetscCall(PetscSFBcastBegin(by_number, MPIU_INT, root.data(), leaves.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastEnd(by_number, MPIU_INT, root.data(), leaves.data(), MPI_REPLACE));
    PetscFunctionReturn(0);
  };
  PetscCall(meet(MPI_MIN, PETSC_MAX_INT, owner));  // the lowest rank holding the vertex
  for (PetscInt v = 0; v < nv; ++v) point[v] = owner[v] == rank ? nc + v : -1;
  PetscCall(meet(MPI_MAX, -1, point));  // its point on that rank
  PetscCall(PetscSFDestroy(&by_number));
  std::vector<PetscInt> leaves;
  std::vector<PetscSFNode> remote;
  for (PetscInt v = 0; v < nv; ++v)
    if (owner[v] != rank) {
      leaves.push_back(nc + v);
      remote.push_back({owner[v], point[v]});
    }
  PetscSF point_sf;
  PetscCall(PetscSFCreate(comm, &point_sf));
  PetscCall(PetscSFSetGraph(point_sf, nc + nv, (PetscInt)leaves.size(), leaves.data(), PETSC_COPY_VALUES, remote.data(),
                            PETSC_COPY_VALUES));
  PetscCall(DMSetPointSF(*dm, point_sf));
  PetscCall(PetscSFDestroy(&point_sf));
  PetscFunctionReturn(0);
}

// The point data of a piece (see PointData), fixed per local vertex and cell_material per local tet.
static PointData piece_point_data(const MeshPiece& piece, const std::vector<int32_t>& fixed,
                                  const std::vector<int32_t>& cell_material) {
  const TetMesh& m = piece.mesh;
  const int64_t count[4] = {m.num_tets(), m.num_segments(), m.num_triangles(), m.num_hinges()};
  const std::vector<int32_t>* tags[4] = {&m.tet_tags, &m.segment_tags, &m.triangle_tags, nullptr};
  PointData d;
  int64_t e = 0;  // index into element_numbers (tets, segments, triangles)
  for (int k = 0; k < 4; ++k)
    for (int64_t i = 0; i < count[k]; ++i) {
      d.kind.push_back(k);
      d.value.push_back(tags[k] ? (*tags[k])[i] : 0);
      d.flag.push_back(k == kTetCell && !cell_material.empty() ? cell_material[i]
                       : k == kTriangleCell                     ? m.triangle_edges[i]
                                                                : 0);
      d.number.push_back(k < kHingeCell ? piece.element_numbers[e++] : -1);
    }
  for (int64_t v = 0; v < m.num_vertices(); ++v) {
    d.kind.push_back(-1);
    d.value.push_back(m.vertex_ids[v]);
    d.flag.push_back(fixed.empty() ? 0 : fixed[v]);
    d.number.push_back(piece.vertex_numbers[v]);
  }
  return d;
}

// Section with `components` dofs on free vertices and none on fixed ones.
static PetscErrorCode create_dof_section(DM dm, const DistributedMesh& m, PetscInt components) {
  PetscSection s;
  PetscInt pStart, pEnd, vStart, vEnd;
  PetscFunctionBeginUser;
  PetscCall(PetscSectionCreate(PetscObjectComm((PetscObject)dm), &s));
  PetscCall(PetscSectionSetNumFields(s, 1));
  PetscCall(PetscSectionSetFieldName(s, 0, "position"));
  PetscCall(PetscSectionSetFieldComponents(s, 0, components));
  PetscCall(DMPlexGetChart(dm, &pStart, &pEnd));
  PetscCall(PetscSectionSetChart(s, pStart, pEnd));
  PetscCall(DMPlexGetDepthStratum(dm, 0, &vStart, &vEnd));
  for (PetscInt v = vStart; v < vEnd; ++v) {
    PetscInt ndof = m.fixed[v - vStart] ? 0 : components;
    PetscCall(PetscSectionSetDof(s, v, ndof));
    PetscCall(PetscSectionSetFieldDof(s, v, 0, ndof));
  }
  PetscCall(PetscSectionSetUp(s));
  PetscCall(DMSetLocalSection(dm, s));
  PetscCall(PetscSectionDestroy(&s));
  PetscFunctionReturn(0);
}

// Fills the flat per-rank arrays from the distributed DM and its point data.
static PetscErrorCode fill_local_arrays(DistributedMesh& m, const PointData& data) {
  const std::vector<int64_t>& point_value = data.value;
  const std::vector<int32_t>& point_flag = data.flag;
  const std::vector<int32_t>& cell_kind = data.kind;
  const std::vector<int64_t>& serial_point = data.number;
  PetscInt cStart, cEnd, vStart, vEnd;
  PetscFunctionBeginUser;
  PetscCall(DMPlexGetHeightStratum(m.dm, 0, &cStart, &cEnd));
  PetscCall(DMPlexGetDepthStratum(m.dm, 0, &vStart, &vEnd));
  m.num_vertices = vEnd - vStart;

  std::vector<PetscInt>* vertices[4] = {&m.cells, &m.segments, &m.triangles, &m.hinges};
  for (std::vector<PetscInt>* v : vertices) v->clear();
  m.cell_tags.clear();
  m.cell_material.clear();
  m.segment_tags.clear();
  m.triangle_tags.clear();
  m.triangle_edges.clear();
  m.cell_ids.clear();
  m.segment_ids.clear();
  m.triangle_ids.clear();
  for (PetscInt c = cStart; c < cEnd; ++c) {
    const PetscInt* cone;
    PetscInt n;
    const int32_t kind = cell_kind[c];
    PetscCall(DMPlexGetConeSize(m.dm, c, &n));
    PetscCheck(kind >= 0 && kind < 4 && n == kCellSize[kind], PETSC_COMM_SELF, PETSC_ERR_PLIB,
               "cell %" PetscInt_FMT " of kind %d has %" PetscInt_FMT " vertices", c, (int)kind, n);
    PetscCall(DMPlexGetCone(m.dm, c, &cone));
    for (int k = 0; k < n; ++k) vertices[kind]->push_back(cone[k] - vStart);
    if (kind == kTetCell) {
      m.cell_tags.push_back((int32_t)point_value[c]);
      m.cell_material.push_back(point_flag[c]);
      m.cell_ids.push_back(serial_point[c]);
    } else if (kind == kSegmentCell) {
      m.segment_tags.push_back((int32_t)point_value[c]);
      m.segment_ids.push_back(serial_point[c]);
    } else if (kind == kTriangleCell) {
      m.triangle_tags.push_back((int32_t)point_value[c]);
      m.triangle_edges.push_back((uint8_t)point_flag[c]);
      m.triangle_ids.push_back(serial_point[c]);
    }
  }
  m.num_cells = (PetscInt)m.cell_tags.size();
  m.num_segments = (PetscInt)m.segment_tags.size();
  m.num_triangles = (PetscInt)m.triangle_tags.size();
  m.num_hinges = (PetscInt)m.hinges.size() / 4;

  Vec coords;
  const PetscScalar* xc;
  PetscCall(DMGetCoordinatesLocal(m.dm, &coords));
  PetscCall(VecGetArrayRead(coords, &xc));
  m.rest.assign(xc, xc + 3 * m.num_vertices);
  PetscCall(VecRestoreArrayRead(coords, &xc));

  m.vertex_ids.assign(point_value.begin() + vStart, point_value.begin() + vEnd);
  m.fixed.assign(point_flag.begin() + vStart, point_flag.begin() + vEnd);

  // Ownership: a vertex that is a leaf of the point SF belongs to another rank.
  PetscSF point_sf;
  PetscInt nleaves;
  const PetscInt* ilocal;
  m.owned.assign(m.num_vertices, 1);
  PetscCall(DMGetPointSF(m.dm, &point_sf));
  PetscCall(PetscSFGetGraph(point_sf, nullptr, &nleaves, &ilocal, nullptr));
  for (PetscInt i = 0; i < nleaves; ++i) {
    PetscInt p = ilocal ? ilocal[i] : i;
    if (p >= vStart && p < vEnd) m.owned[p - vStart] = 0;
  }
  PetscFunctionReturn(0);
}

static PetscErrorCode fill_dof_numbers(DistributedMesh& m) {
  PetscSection ls, gs;
  PetscInt vStart, vEnd;
  PetscFunctionBeginUser;
  PetscCall(DMGetLocalSection(m.dm, &ls));
  PetscCall(DMGetGlobalSection(m.dm, &gs));
  PetscCall(DMPlexGetDepthStratum(m.dm, 0, &vStart, &vEnd));
  m.local_dof.assign(m.num_vertices, -1);
  m.global_dof.assign(m.num_vertices, -1);
  for (PetscInt v = vStart; v < vEnd; ++v) {
    if (m.fixed[v - vStart]) continue;
    PetscInt loff, goff;
    PetscCall(PetscSectionGetOffset(ls, v, &loff));
    PetscCall(PetscSectionGetOffset(gs, v, &goff));
    m.local_dof[v - vStart] = loff;
    m.global_dof[v - vStart] = goff >= 0 ? goff : -(goff + 1);  // ghosts are stored as -(offset+1)
  }
  PetscFunctionReturn(0);
}

std::vector<PetscInt> body_elements(const DistributedMesh& m, const std::vector<PetscInt>& vertices, int size, int body) {
  std::vector<PetscInt> elements;
  for (PetscInt e = 0; e < (PetscInt)vertices.size() / size; ++e)
    if (body < 0 || m.vertex_body[vertices[size * e]] == body) elements.push_back(e);
  return elements;
}

void rest_bounding_box(const DistributedMesh& m, double lo[3], double hi[3]) {
  bounding_box(m.rest, lo, hi);
  MPI_Comm comm = PetscObjectComm((PetscObject)m.dm);
  MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
  MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
}

double rest_diagonal(const DistributedMesh& m) {
  double lo[3], hi[3];
  rest_bounding_box(m, lo, hi);
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

PetscErrorCode distribute_mesh(MPI_Comm comm, const MeshPiece& piece, const std::vector<int32_t>& fixed,
                               const std::vector<int32_t>& cell_material, DistributedMesh& out) {
  PetscFunctionBeginUser;
  DM dm;
  PointData data = piece_point_data(piece, fixed, cell_material);
  PetscCall(create_piece_plex(comm, piece, &dm));
  PetscCall(DMPlexDistributeSetDefault(dm, PETSC_FALSE));  // never re-partition behind our back
  out.dm = dm;
  PetscCall(fill_local_arrays(out, data));
  out.tagged_faces = piece.mesh.tagged_faces;
  PetscCall(create_dof_section(out.dm, out, 3));
  // Same points, same order, 1 dof instead of 3: vertex dof i of vertex_dm is dof 3i of dm.
  PetscCall(DMClone(out.dm, &out.vertex_dm));
  PetscCall(create_dof_section(out.vertex_dm, out, 1));
  PetscCall(fill_dof_numbers(out));

  // Global counts.
  PetscInt local[6] = {out.num_cells, 0, 0, out.num_segments, out.num_triangles, out.num_hinges}, global[6];
  for (PetscInt v = 0; v < out.num_vertices; ++v)
    if (out.owned[v]) {
      local[1]++;
      if (out.fixed[v]) local[2]++;
    }
  PetscCallMPI(MPI_Allreduce(local, global, 6, MPIU_INT, MPI_SUM, comm));
  out.global_cells = global[0];
  out.global_vertices = global[1];
  out.global_fixed_vertices = global[2];
  out.global_segments = global[3];
  out.global_triangles = global[4];
  out.global_hinges = global[5];
  out.global_dofs = 3 * (global[1] - global[2]);
  PetscFunctionReturn(0);
}

}  // namespace hyperqn

namespace hyperqn {

namespace {

// Bytes between two ranks in pieces of at most 1 GiB (MPI counts are ints). A length of -1 says
// that the sender failed.
constexpr int64_t kMaxMessage = int64_t(1) << 30;
void send_bytes(MPI_Comm comm, int to, const std::vector<char>& bytes, bool failed) {
  const int64_t n = failed ? -1 : (int64_t)bytes.size();
  MPI_Send(&n, 1, MPI_INT64_T, to, 0, comm);
  for (int64_t at = 0; at < n; at += kMaxMessage)
    MPI_Send(bytes.data() + at, (int)std::min(kMaxMessage, n - at), MPI_BYTE, to, 0, comm);
}
bool receive_bytes(MPI_Comm comm, int from, std::vector<char>& bytes) {
  int64_t n;
  MPI_Recv(&n, 1, MPI_INT64_T, from, 0, comm, MPI_STATUS_IGNORE);
  if (n < 0) return false;
  bytes.resize(n);
  for (int64_t at = 0; at < n; at += kMaxMessage)
    MPI_Recv(bytes.data() + at, (int)std::min(kMaxMessage, n - at), MPI_BYTE, from, 0, comm, MPI_STATUS_IGNORE);
  return true;
}

}  // namespace

// `root` cuts the pieces of ranks root .. root + count - 1 (cut hands them over part by part) and
// sends each rank its own, keeping part 0; every rank of the group returns its piece, or throws
// std::runtime_error if root failed (with root's reason on root). Ranks outside the group do not
// take part; a rank that got its piece before root failed does not know (callers agree after).
static MeshPiece hand_out(MPI_Comm comm, int root, int count,
                          const std::function<void(const std::function<void(int, MeshPiece&)>&)>& cut) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  MeshPiece mine;
  if (rank == root) {
    int sent = 1;  // parts handed out (part 0 stays)
    try {
      cut([&](int part, MeshPiece& piece) {
        if (part == 0) {
          mine = std::move(piece);
          return;
        }
        send_bytes(comm, root + part, pack_piece(piece), false);
        sent = part + 1;
      });
    } catch (const std::exception& e) {
      for (int p = sent; p < count; ++p) send_bytes(comm, root + p, {}, true);
      throw;
    }
  } else {
    std::vector<char> bytes;
    if (!receive_bytes(comm, root, bytes)) throw std::runtime_error("rank " + std::to_string(root) + " could not cut the mesh");
    mine = unpack_piece(bytes);
  }
  return mine;
}

MeshPiece scatter_serial_mesh(MPI_Comm comm, const TetMesh& serial) {
  int size;
  MPI_Comm_size(comm, &size);
  MeshPiece mine;
  std::string error;
  try {
    mine = hand_out(comm, 0, size, [&](const auto& fn) { pieces_of_serial_mesh(serial, size, fn); });
  } catch (const std::exception& e) {
    error = e.what();
  }
  // Ranks that got their piece before rank 0 failed learn it here.
  int failed = !error.empty();
  MPI_Allreduce(MPI_IN_PLACE, &failed, 1, MPI_INT, MPI_MAX, comm);
  if (failed) throw std::runtime_error(error.empty() ? "rank 0 could not cut the mesh" : error);
  return mine;
}

MeshPiece share_piece(MPI_Comm comm, int root, int count, const MeshPiece* piece) {
  return hand_out(comm, root, count, [&](const auto& fn) {
    if (!piece) throw std::runtime_error("rank " + std::to_string(root) + " has no piece to share");
    split_piece(*piece, count, fn);
  });
}

}  // namespace hyperqn
