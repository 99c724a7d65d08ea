#include "mesh/distributed_mesh.hpp"

#include <metis.h>
#include <petscsf.h>

#include <algorithm>
#include <cmath>
#include <numeric>

namespace hyperqn {

// The kinds of cells, in the order the serial DMPlex numbers them.
enum CellKind : int32_t { kTetCell, kSegmentCell, kTriangleCell, kHingeCell };
constexpr int kCellSize[4] = {4, 2, 3, 4};

// The serial mesh's elements as cells: per kind, its vertex lists (rank 0).
struct SerialCells {
  const std::vector<int32_t>* vertices[4];
  int64_t count[4];
  explicit SerialCells(const TetMesh& m)
      : vertices{&m.tets, &m.segments, &m.triangles, &m.hinges},
        count{m.num_tets(), m.num_segments(), m.num_triangles(), m.num_hinges()} {}
  int64_t total() const { return count[0] + count[1] + count[2] + count[3]; }
};

// Element partition of the serial mesh (cells in the order of SerialCells): METIS k-way on the
// dual graph. Tets are neighbours when they share a face, triangles (and hinges) an edge; with
// strands, elements sharing a vertex are, since consecutive segments share only that.
static std::vector<PetscInt> metis_partition(const TetMesh& mesh, int nparts) {
  const SerialCells cells(mesh);
  idx_t ne = (idx_t)cells.total(), nn = (idx_t)mesh.num_vertices();
  std::vector<PetscInt> part(ne, 0);
  if (nparts == 1 || ne == 0) return part;
  std::vector<idx_t> eptr(1, 0), eind;
  eind.reserve(4 * size_t(ne));
  for (int k = 0; k < 4; ++k) {
    eind.insert(eind.end(), cells.vertices[k]->begin(), cells.vertices[k]->end());
    for (int64_t e = 0; e < cells.count[k]; ++e) eptr.push_back(eptr.back() + kCellSize[k]);
  }
  idx_t ncommon = cells.count[kSegmentCell] > 0 ? 1 : cells.count[kTriangleCell] > 0 ? 2 : 3, np = nparts, objval = 0;
  idx_t opts[METIS_NOPTIONS];
  METIS_SetDefaultOptions(opts);
  opts[METIS_OPTION_SEED] = 7;  // fixed seed: the same partition on every run
  std::vector<idx_t> epart(ne), npart(nn);
  int status = METIS_PartMeshDual(&ne, &nn, eptr.data(), eind.data(), nullptr, nullptr, &ncommon, &np,
                                  nullptr, opts, &objval, epart.data(), npart.data());
  if (status != METIS_OK) return {};
  std::copy(epart.begin(), epart.end(), part.begin());
  return part;
}

// The serial DMPlex on rank 0 (empty elsewhere): non-interpolated (vertex dofs need no edges or
// faces), points = cells (tets, segments, triangles, hinges), then vertices.
static PetscErrorCode create_serial_plex(MPI_Comm comm, const TetMesh& serial, DM* dm) {
  PetscMPIInt rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  const SerialCells cells(serial);
  const PetscInt nc = rank == 0 ? (PetscInt)cells.total() : 0;
  const PetscInt nv = rank == 0 ? (PetscInt)serial.num_vertices() : 0;
  PetscInt num_points[2] = {nv, nc};  // by depth: vertices, cells
  std::vector<PetscInt> cone_size(nc + nv, 0), cones, orientations;
  if (rank == 0)
    for (int k = 0, c = 0; k < 4; ++k) {
      for (int64_t e = 0; e < cells.count[k]; ++e) cone_size[c++] = kCellSize[k];
      for (int32_t v : *cells.vertices[k]) cones.push_back(nc + v);  // vertex points come after the cells
    }
  orientations.assign(cones.size(), 0);
  PetscCall(DMCreate(comm, dm));
  PetscCall(DMSetType(*dm, DMPLEX));
  PetscCall(DMSetDimension(*dm, 3));
  PetscCall(DMPlexCreateFromDAG(*dm, 1, num_points, cone_size.data(), cones.data(), orientations.data(),
                                serial.coords.data()));
  // DMPlexDistribute orders the migrated points of a non-interpolated mesh by the dimension of
  // their cell type, cells (3) and vertices (0) only: a segment or a triangle, typed as a 1- or
  // 2-dimensional polytope, would get no place (PETSc 3.18 then fails with duplicate SF leaves).
  // Every element is a cell of this mesh like a tet, so it is typed like one; nothing else reads
  // the cell type.
  if (nc > 0) {
    DMLabel cell_type;
    PetscCall(DMPlexGetCellTypeLabel(*dm, &cell_type));
    for (PetscInt c = 0; c < nc; ++c) {
      PetscInt type;
      PetscCall(DMLabelGetValue(cell_type, c, &type));
      if (type == DM_POLYTOPE_TETRAHEDRON) continue;
      PetscCall(DMLabelClearValue(cell_type, c, type));
      PetscCall(DMLabelSetValue(cell_type, c, DM_POLYTOPE_TETRAHEDRON));
    }
  }
  PetscFunctionReturn(0);
}

// Rank 0 computes the METIS partition and gives it to the shell partitioner; the other ranks
// hold no cells and pass empty sizes.
static PetscErrorCode set_metis_partition(DM dm, const TetMesh& serial) {
  PetscMPIInt size, rank;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_size(PetscObjectComm((PetscObject)dm), &size));
  PetscCallMPI(MPI_Comm_rank(PetscObjectComm((PetscObject)dm), &rank));
  std::vector<PetscInt> sizes(size, 0), points;
  if (rank == 0) {
    std::vector<PetscInt> part = metis_partition(serial, size);
    PetscCheck(part.size() == (size_t)SerialCells(serial).total(), PETSC_COMM_SELF, PETSC_ERR_LIB,
               "METIS partitioning failed");
    for (PetscInt p : part) sizes[p]++;
    std::vector<PetscInt> start(size, 0);
    for (int p = 1; p < size; ++p) start[p] = start[p - 1] + sizes[p - 1];
    points.resize(part.size());
    for (PetscInt c = 0; c < (PetscInt)part.size(); ++c) points[start[part[c]]++] = c;
  }
  PetscPartitioner partitioner;
  PetscCall(DMPlexGetPartitioner(dm, &partitioner));
  PetscCall(PetscPartitionerSetType(partitioner, PETSCPARTITIONERSHELL));
  PetscCall(PetscPartitionerShellSetPartition(partitioner, size, sizes.data(), points.data()));
  PetscFunctionReturn(0);
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

// Fills the flat per-rank arrays from the distributed DM. point_value[p] is the input element
// tag of cell p or the input vertex index of vertex p; point_flag[p] is the material of a tet,
// the carried edges of a triangle, or the fixed flag of vertex p; cell_kind[p] the CellKind of
// cell p; serial_point[p] the number of cell p in the serial DMPlex.
static PetscErrorCode fill_local_arrays(DistributedMesh& m, const std::vector<int64_t>& point_value,
                                        const std::vector<int32_t>& point_flag, const std::vector<int32_t>& cell_kind,
                                        const std::vector<int64_t>& serial_point) {
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

void rest_bounding_box(const DistributedMesh& m, double lo[3], double hi[3]) {
  for (int d = 0; d < 3; ++d) {
    lo[d] = HUGE_VAL;
    hi[d] = -HUGE_VAL;
  }
  for (PetscInt v = 0; v < m.num_vertices; ++v)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], m.rest[3 * v + d]);
      hi[d] = std::max(hi[d], m.rest[3 * v + d]);
    }
  MPI_Comm comm = PetscObjectComm((PetscObject)m.dm);
  MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
  MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
}

double rest_diagonal(const DistributedMesh& m) {
  double lo[3], hi[3];
  rest_bounding_box(m, lo, hi);
  return std::hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]);
}

PetscErrorCode distribute_mesh(MPI_Comm comm, const TetMesh& serial, const std::vector<int32_t>& fixed_serial,
                               const std::vector<int32_t>& cell_material, DistributedMesh& out) {
  PetscMPIInt rank, size;
  PetscFunctionBeginUser;
  PetscCallMPI(MPI_Comm_rank(comm, &rank));
  PetscCallMPI(MPI_Comm_size(comm, &size));

  // The whole mesh is created on rank 0, then distributed.
  const SerialCells cells(serial);
  const PetscInt ncells = rank == 0 ? (PetscInt)cells.total() : 0;
  const PetscInt nverts = rank == 0 ? (PetscInt)serial.num_vertices() : 0;
  DM dm;
  PetscCall(create_serial_plex(comm, serial, &dm));
  PetscCall(DMPlexDistributeSetDefault(dm, PETSC_FALSE));  // never re-partition behind our back

  // Per serial point (cells first, then vertices): the data that travels with it.
  std::vector<int64_t> point_value(ncells + nverts);
  std::vector<int32_t> point_flag(ncells + nverts, 0), cell_kind(ncells + nverts, -1);
  std::vector<int64_t> serial_point(ncells + nverts);
  std::iota(serial_point.begin(), serial_point.end(), 0);
  if (rank == 0) {
    const std::vector<int32_t>* tags[4] = {&serial.tet_tags, &serial.segment_tags, &serial.triangle_tags, nullptr};
    for (int k = 0, c = 0; k < 4; ++k)
      for (int64_t e = 0; e < cells.count[k]; ++e, ++c) {
        cell_kind[c] = k;
        point_value[c] = tags[k] ? (*tags[k])[e] : 0;
        if (k == kTetCell && !cell_material.empty()) point_flag[c] = cell_material[e];
        if (k == kTriangleCell) point_flag[c] = serial.triangle_edges[e];
      }
  }
  for (PetscInt v = 0; v < nverts; ++v) {
    point_value[ncells + v] = serial.vertex_ids[v];
    point_flag[ncells + v] = fixed_serial[v];
  }

  if (size > 1) {
    PetscSF migration;
    DM dist;
    PetscInt pStart, pEnd;
    PetscCall(set_metis_partition(dm, serial));
    PetscCall(DMPlexDistribute(dm, 0, &migration, &dist));
    PetscCall(DMPlexGetChart(dist, &pStart, &pEnd));
    // The migration SF's roots are the serial points on rank 0, its leaves the new local points.
    std::vector<int64_t> value(pEnd - pStart);
    std::vector<int32_t> flag(pEnd - pStart), kind(pEnd - pStart);
    std::vector<int64_t> number(pEnd - pStart);
    PetscCall(PetscSFBcastBegin(migration, MPI_INT64_T, point_value.data(), value.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastEnd(migration, MPI_INT64_T, point_value.data(), value.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastBegin(migration, MPI_INT32_T, point_flag.data(), flag.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastEnd(migration, MPI_INT32_T, point_flag.data(), flag.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastBegin(migration, MPI_INT32_T, cell_kind.data(), kind.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastEnd(migration, MPI_INT32_T, cell_kind.data(), kind.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastBegin(migration, MPI_INT64_T, serial_point.data(), number.data(), MPI_REPLACE));
    PetscCall(PetscSFBcastEnd(migration, MPI_INT64_T, serial_point.data(), number.data(), MPI_REPLACE));
    PetscCall(PetscSFDestroy(&migration));
    PetscCall(DMDestroy(&dm));
    dm = dist;
    point_value.swap(value);
    point_flag.swap(flag);
    cell_kind.swap(kind);
    serial_point.swap(number);
  }
  out.dm = dm;
  PetscCall(fill_local_arrays(out, point_value, point_flag, cell_kind, serial_point));
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
  // The serial DMPlex numbers tets, then segments, then triangles: an element's index in its kind.
  for (int64_t& id : out.segment_ids) id -= out.global_cells;
  for (int64_t& id : out.triangle_ids) id -= out.global_cells + out.global_segments;
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
