#include "model/scene.hpp"

#include <cstdio>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <functional>
#include <numeric>

#include "io/atomic_file.hpp"
#include "io/log_events.hpp"
#include "io/partition_file.hpp"
#include "model/cuts.hpp"
#include "model/fracture.hpp"
#include "model/tearing.hpp"
#include "model/elastic_terms.hpp"
#include "model/load_kinds.hpp"
#include "terms/boundary_faces.hpp"
#include "terms/contact.hpp"
#include "model/initial_state.hpp"
#include "model/regions.hpp"
#include "mesh/input_error.hpp"
#include "geometry/surface_file.hpp"
#include "mesh/mesh_gmsh.hpp"
#include "model/memory_estimate.hpp"
#include "solvers/solver_registry.hpp"
#include "io/console.hpp"

namespace hyperqn {

namespace {

// Runs fn on rank 0 only; an exception there is re-thrown on every rank as an InputError, so all
// ranks stop together with the same message.
void on_root(MPI_Comm comm, const std::function<void()>& fn) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  std::string error;
  if (rank == 0) {
    try {
      fn();
    } catch (const InputError& e) {
      error = e.what();
      if (error.empty()) error = "input error";
    } catch (const std::bad_alloc&) {
      error = "out of memory while reading the mesh on rank 0";
    } catch (const std::exception& e) {  // rank 0 alone must not throw: the others wait below
      error = std::string("reading the mesh: ") + e.what();
    }
  }
  int n = (int)error.size();
  MPI_Bcast(&n, 1, MPI_INT, 0, comm);
  if (n == 0) return;
  error.resize(n);
  MPI_Bcast(error.data(), n, MPI_CHAR, 0, comm);
  throw InputError(error);
}

// Every rank's memory limit, on rank 0 (collective; an error in HYPERQN_MEMORY_LIMIT_MB on any rank
// is the same InputError on every rank).
std::vector<MemoryLimit> gather_memory_limits(MPI_Comm comm) {
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  MemoryLimit mine;
  std::string error;
  try {
    mine = rank_memory_limit(comm);
  } catch (const InputError& e) {
    error = e.what();
  }
  try {
    throw_if_any_failed(comm, error);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  const double sent[4] = {mine.bytes, double(mine.from_environment), double(mine.node_ranks), mine.node_available};
  std::vector<double> all(rank == 0 ? 4 * size_t(size) : 0);
  MPI_Gather(sent, 4, MPI_DOUBLE, all.data(), 4, MPI_DOUBLE, 0, comm);
  std::vector<MemoryLimit> limits(all.size() / 4);
  for (size_t r = 0; r < limits.size(); ++r)
    limits[r] = {all[4 * r], all[4 * r + 1] != 0, int(all[4 * r + 2]), all[4 * r + 3]};
  return limits;
}

// On rank 0: refuses a mesh of `vertices` vertices if a rank of the run would need more memory than
// it may take (estimated_rank_memory against its limit), naming the deck key that sets the mesh's
// size, the rank, what it holds and the ways out. -hyperqn_memory_report prints every rank's
// estimate (bench/memory_per_rank.py reads it).
void check_memory(const SceneSpec& deck, int64_t vertices, int64_t tets, const MemoryPlan& run_plan,
                  const std::vector<MemoryLimit>& limits, int line = 0, const std::string& key = "") {
  const int ranks = (int)limits.size();
  const MemoryPlan plan = resolved_plan(run_plan, vertices, tets, ranks);
  // A flag, or a bool (-hyperqn_memory_report false, petsc: {hyperqn_memory_report: false}): its
  // value is checked by read_run_options.
  PetscBool report = PETSC_FALSE;
  PetscOptionsGetBool(nullptr, nullptr, "-hyperqn_memory_report", &report, nullptr);
  std::vector<double> bytes(ranks);
  int worst = -1;
  double worst_ratio = 1;
  for (int r = 0; r < ranks; ++r) {
    bytes[r] = limits[r].bytes;
    const RankMemory m = estimated_rank_memory(vertices, ranks, r, plan);
    if (report)
      PetscPrintf(PETSC_COMM_SELF, "hyperqn: memory estimate rank %d: about %.0f MB of %.0f MB (%s): %s\n", r,
                  m.total() / 1048576.0, limits[r].bytes / 1048576.0, describe_limit(limits[r]).c_str(),
                  describe_rank_memory(m, r, plan).c_str());
    if (limits[r].bytes > 0 && m.total() / limits[r].bytes > worst_ratio) {
      worst = r;
      worst_ratio = m.total() / limits[r].bytes;
    }
  }
  if (worst < 0) return;
  const RankMemory m = estimated_rank_memory(vertices, ranks, worst, plan);
  char head[400];
  std::snprintf(head, sizeof head,
                "rank %d of %d would need about %.0f MB of memory (estimate for %lld vertices, docs/guardrails.md#memory) "
                "but %.0f MB are available to it (%s). ",
                worst, ranks, m.total() / 1048576.0, (long long)vertices, limits[worst].bytes / 1048576.0,
                describe_limit(limits[worst]).c_str());
  throw InputError(deck.path, line ? line : deck.mesh.line,
                   !key.empty() ? key : deck.mesh.is_box ? "mesh.box.cells" : deck.mesh.is_sheet ? "mesh.sheet.cells" : "mesh.file",
                   head + ("It would hold " + describe_rank_memory(m, worst, plan)) + ". Ways out: " +
                       ways_out(vertices, ranks, plan, bytes));
}

// An OBJ surface as a cloth mesh: vertex ids are the vertices' 0-based positions in the file.
TetMesh surface_mesh(const TriangleSurface& surface) {
  TetMesh mesh;
  for (const Eigen::Vector3d& x : surface.vertices) mesh.coords.insert(mesh.coords.end(), x.data(), x.data() + 3);
  for (const auto& t : surface.triangles) mesh.triangles.insert(mesh.triangles.end(), t.begin(), t.end());
  mesh.triangle_tags.assign(surface.triangles.size(), 0);
  for (size_t f = 0; f < surface.triangle_lines.size(); ++f) mesh.triangle_lines.add(int64_t(f), surface.triangle_lines[f]);
  mesh.vertex_ids.resize(surface.vertices.size());
  for (size_t v = 0; v < surface.vertices.size(); ++v) mesh.vertex_ids[v] = int64_t(v);
  return mesh;
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

// A body between a micrometre and a million kilometres across (its rest bounding box's diagonal).
// Far above, its mass (density x size^3) and energies (E x size^3) leave the number limits of
// params/key_range.hpp for values of density and E within them, and the run ends in an overflow;
// far below, its gradient underflows to 0 (a body that never moves), and already at 1e-8 m the
// inertial guess of a clamped cube under gravity (h^2 g = 9e-3 m: 1e6 times its size) stretched it
// past what the solvers brought back (diverged at 1e-8 and 1e-9 m, ran at 1e-7 and 1e-6 m).
constexpr double kSmallestBody = 1e-6, kLargestBody = 1e9;
// ... and at most this many times its size from the origin (a box moved 1e16 m away collapsed to
// points: non-finite energies in the first frame).
constexpr double kFarthestBody = 1e6;

// The corners of a mesh's bounding box, lo then hi (lo > hi for a mesh without vertices).
static std::array<double, 6> bounding_box(const TetMesh& mesh) {
  std::array<double, 6> box{HUGE_VAL, HUGE_VAL, HUGE_VAL, -HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
  for (int64_t v = 0; v < mesh.num_vertices(); ++v)
    for (int d = 0; d < 3; ++d) {
      box[d] = std::min(box[d], mesh.coords[3 * v + d]);
      box[3 + d] = std::max(box[3 + d], mesh.coords[3 * v + d]);
    }
  return box;
}

// The plan for the deck's box mesh ([0, box.size] after mesh.transform: its corners' bounding box;
// with strands auto goes by no deflection scale, Scene::weight_deflection).
static MemoryPlan with_box_mesh(MemoryPlan plan, const MeshSpec& spec) {
  if (!spec.strands.empty()) plan.held_weight = 0;
  TetMesh corners;
  for (int c = 0; c < 8; ++c)
    for (int d = 0; d < 3; ++d) corners.coords.push_back(c >> d & 1 ? spec.box_size[d] : 0.0);
  apply_transform(corners, spec.transform);
  const std::array<double, 6> box = bounding_box(corners);
  return with_rest_box(plan, box.data(), box.data() + 3);
}

// An InputError naming the mesh's size key (key_prefix "mesh" or "bodies[k].mesh") when the mesh,
// whose bounding box (after its transform) is `box`, is not within kSmallestBody .. kLargestBody across.
static void check_body_size(const std::array<double, 6>& box, const MeshSpec& spec, const std::string& deck_path,
                            const std::string& key_prefix) {
  if (box[0] > box[3]) return;
  const double diagonal = std::hypot(box[3] - box[0], box[4] - box[1], box[5] - box[2]);
  const double farthest = std::hypot(std::max(std::fabs(box[0]), std::fabs(box[3])),
                                     std::max(std::fabs(box[1]), std::fabs(box[4])),
                                     std::max(std::fabs(box[2]), std::fabs(box[5])));
  if (diagonal >= kSmallestBody && diagonal <= kLargestBody && farthest > kFarthestBody * diagonal) {
    const bool moved = spec.transform.translate != std::array<double, 3>{0, 0, 0};
    char msg[400];
    std::snprintf(msg, sizeof msg,
                  "the body lies up to %.3g m from the origin, more than %g times its size (%.3g m across, after "
                  "mesh.transform): its coordinates would keep fewer than 10 of their 16 digits for its shape. Move "
                  "the scene nearer the origin",
                  farthest, kFarthestBody, diagonal);
    throw InputError(deck_path, spec.line, key_prefix + (moved ? ".transform.translate" : spec.file.empty() ? ".strands" : ".file"), msg);
  }
  if (diagonal >= kSmallestBody && diagonal <= kLargestBody) return;
  const std::string key = key_prefix + (spec.transform.scale != 1.0 ? ".transform.scale"
                                        : spec.is_box                 ? ".box.size"
                                        : spec.is_sheet               ? ".sheet.size"
                                        : !spec.file.empty()          ? ".file"
                                                                      : ".strands");
  char msg[400];
  std::snprintf(msg, sizeof msg,
                "the body's rest bounding-box diagonal would be %.3g m (after mesh.transform); hyperqn takes bodies "
                "from %g to %g m across, where their masses and energies stay within the numbers it can "
                "represent. Check the size, the scale and their units",
                diagonal, kSmallestBody, kLargestBody);
  throw InputError(deck_path, spec.line, key, msg);
}

// One mesh as a MeshSpec describes it: made or read (with the triangles of face_tags: TetMesh::tagged_faces),
// transformed, its strands added, cleaned (errors name `deck_path` for a generated mesh), its size
// checked (check_body_size; key_prefix names its deck key).
static TetMesh read_mesh_spec(const MeshSpec& spec, const std::string& deck_path, CleanReport* repaired,
                              const std::string& key_prefix, const std::vector<int32_t>& face_tags = {}) {
  TetMesh mesh;
  if (spec.is_box) {
    mesh = generate_box(spec.box_size, spec.box_cells);
  } else if (spec.is_sheet) {
    mesh = generate_sheet(spec.sheet_size, spec.sheet_cells);
  } else if (ends_with(spec.file, ".obj")) {
    mesh = surface_mesh(read_triangle_surface(spec.file));
  } else if (ends_with(spec.file, ".msh")) {
    mesh = read_gmsh(spec.file, spec.surface_as_cloth, face_tags);
  } else if (!spec.file.empty()) {
    mesh = read_medit(spec.file, spec.edges_as_strands, spec.surface_as_cloth, face_tags);
  }
  apply_transform(mesh, spec.transform);
  for (const StrandLine& strand : spec.strands) add_strand(mesh, strand);
  const CleanReport report = clean_mesh(mesh, spec.file.empty() ? deck_path : spec.file);
  if (repaired) *repaired = report;
  check_body_size(bounding_box(mesh), spec, deck_path, key_prefix);
  return mesh;
}

// A scene of bodies as one mesh: each body's mesh read alone (read_mesh_spec: a cloth's hinges
// and carried edges come from its own triangles, a strand ties to its own body), its elements
// tagged with the body's index, then appended: vertex ids body by body.
static TetMesh read_bodies_mesh(const SceneSpec& deck, CleanReport* repaired) {
  TetMesh all;
  int64_t first_id = 0;
  CleanReport total;
  for (size_t k = 0; k < deck.bodies.size(); ++k) {
    CleanReport report;
    const TetMesh mesh = read_mesh_spec(deck.bodies[k].mesh, deck.path, &report, "bodies[" + std::to_string(k) + "].mesh");
    total.dropped_vertices += report.dropped_vertices;
    total.reoriented_tets += report.reoriented_tets;
    const int32_t first_vertex = (int32_t)all.num_vertices();
    const auto append = [&](const std::vector<int32_t>& from, std::vector<int32_t>& to) {
      for (int32_t v : from) to.push_back(first_vertex + v);
    };
    all.coords.insert(all.coords.end(), mesh.coords.begin(), mesh.coords.end());
    append(mesh.tets, all.tets);
    all.tet_tags.insert(all.tet_tags.end(), mesh.num_tets(), (int32_t)k);
    append(mesh.segments, all.segments);
    all.segment_tags.insert(all.segment_tags.end(), mesh.num_segments(), (int32_t)k);
    append(mesh.triangles, all.triangles);
    all.triangle_tags.insert(all.triangle_tags.end(), mesh.num_triangles(), (int32_t)k);
    all.triangle_edges.insert(all.triangle_edges.end(), mesh.triangle_edges.begin(), mesh.triangle_edges.end());
    append(mesh.hinges, all.hinges);
    int64_t ids = 0;
    for (int64_t id : mesh.vertex_ids) {
      all.vertex_ids.push_back(first_id + id);
      ids = std::max(ids, id + 1);
    }
    first_id += ids;
  }
  if (repaired) *repaired = total;
  return all;
}

// A body has a material exactly when its mesh has tets (read_bodies cannot tell for a Medit file
// read for its edges): checked on the pieces, whichever way they came.
static void check_body_materials(MPI_Comm comm, const SceneSpec& deck, const MeshPiece& piece) {
  std::vector<int64_t> tets(deck.bodies.size(), 0);
  for (int32_t body : piece.mesh.tet_tags) ++tets[body];
  // A tet is in one piece only.
  MPI_Allreduce(MPI_IN_PLACE, tets.data(), (int)tets.size(), MPI_INT64_T, MPI_SUM, comm);
  for (size_t k = 0; k < deck.bodies.size(); ++k) {
    const BodySpec& body = deck.bodies[k];
    const std::string key = "bodies[" + std::to_string(k) + "].material";
    if (tets[k] > 0 && !body.has_material)
      throw InputError(deck.path, body.line, key,
                       "missing: the body's mesh file " + body.mesh.file + " has " + std::to_string(tets[k]) + " tetrahedra");
    if (tets[k] == 0 && body.has_material)
      throw InputError(deck.path, body.line, key, "the body's mesh has no tetrahedra for it to describe");
  }
}

BodiesStamp bodies_stamp(const SceneSpec& deck) {
  std::vector<MeshSpec> meshes;
  for (const BodySpec& body : deck.bodies) meshes.push_back(body.mesh);
  return {int64_t(deck.bodies.size()), mesh_sources_hash(meshes)};
}

// The deck's partition file of bodies (partition:) was written from these bodies: the same count
// and the same hash of their meshes (a changed transform or mesh file makes it stale).
static void check_bodies_partition(const SceneSpec& deck, const PartitionFileInfo& info) {
  const std::string again = ": write it again with hyperqn partition " + deck.path + " -n N";
  if (info.bodies.count == 0)
    throw InputError(deck.path, deck.partition_line, "partition",
                     deck.partition_file + " holds one mesh, not the bodies of a deck" + again);
  if (info.bodies.count != int64_t(deck.bodies.size()))
    throw InputError(deck.path, deck.partition_line, "partition",
                     deck.partition_file + " holds " + std::to_string(info.bodies.count) + " bodies and the deck has " +
                         std::to_string(deck.bodies.size()) + again);
  if (info.bodies.hash != bodies_stamp(deck).hash)
    throw InputError(deck.path, deck.partition_line, "partition",
                     deck.partition_file + " was written from other bodies (a body's mesh, mesh file or transform has "
                     "changed since; it was made from " + info.source + ")" + again);
}

TetMesh read_serial_mesh(const SceneSpec& deck, CleanReport* repaired) {
  if (!deck.bodies.empty()) return read_bodies_mesh(deck, repaired);
  const MeshSpec& spec = deck.mesh;
  TetMesh mesh = read_mesh_spec(spec, deck.path, repaired, "mesh", deck.face_tags());
  if (mesh.num_tets() > 0 && !deck.has_material)
    throw InputError(deck.path, 0, "material", "missing: the mesh file " + spec.file + " has " +
                                                   std::to_string(mesh.num_tets()) + " tetrahedra");
  return mesh;
}

// Every face tag the deck names is on a triangle of the mesh file, and the mesh has tets (rank 0,
// on the serial mesh).
static void check_face_tags_in_file(const SceneSpec& deck, const TetMesh& mesh) {
  const std::vector<SceneSpec::NamedFaceTag> named = deck.named_face_tags();
  if (named.empty()) return;
  const std::string& file = deck.mesh.file;
  if (mesh.num_tets() == 0)
    throw InputError(deck.path, named[0].line, named[0].key,
                     "the mesh " + file + " has no tetrahedra: face_tag selects boundary faces of tets");
  const std::vector<int32_t>& in_file = mesh.tagged_faces.file_tags;
  for (const auto& [key, line, tag] : named) {
    if (std::binary_search(in_file.begin(), in_file.end(), tag)) continue;
    std::string tags;
    for (size_t k = 0; k < in_file.size() && k < 20; ++k) tags += (k ? ", " : "") + std::to_string(in_file[k]);
    if (in_file.size() > 20) tags += ", ...";
    throw InputError(deck.path, line, key,
                     "no triangle of the mesh file " + file + " carries tag " + std::to_string(tag) +
                         (in_file.empty() ? " (it has no tagged triangles)" : " (its triangles' tags: " + tags + ")"));
  }
}

TetMesh load_scene_mesh(MPI_Comm comm, const SceneSpec& deck, CleanReport* repaired, const MemoryPlan& plan) {
  TetMesh mesh;
  const std::vector<MemoryLimit> limits = gather_memory_limits(comm);  // (empty on ranks > 0)
  on_root(comm, [&] {
    const MeshSpec& spec = deck.mesh;
    if (spec.is_box) {  // before generating it
      const auto& n = spec.box_cells;
      check_memory(deck, int64_t(n[0] + 1) * (n[1] + 1) * (n[2] + 1), box_tets(n), with_box_mesh(plan, spec), limits);
    } else if (spec.is_sheet) {
      const auto& n = spec.sheet_cells;
      check_memory(deck, int64_t(n[0] + 1) * (n[1] + 1), 0, plan, limits);
    }
    for (size_t k = 0; k < spec.strands.size(); ++k)  // each strand's vertices, before they are made
      check_memory(deck, spec.strands[k].segments + int64_t(1), 0, plan, limits, spec.strands[k].line,
                   "mesh.strands[" + std::to_string(k) + "].segments");
    mesh = read_serial_mesh(deck, repaired);
    check_face_tags_in_file(deck, mesh);
    if (!spec.file.empty() || !deck.bodies.empty()) {  // before distributing and factoring it
      MemoryPlan known = plan;  // with strands or a cloth auto goes by no deflection scale (Scene::weight_deflection)
      if (!mesh.segments.empty() || !mesh.triangles.empty()) known.held_weight = 0;
      const std::array<double, 6> box = bounding_box(mesh);
      check_memory(deck, mesh.num_vertices(), mesh.num_tets(), with_rest_box(known, box.data(), box.data() + 3), limits);
    }
  });
  return mesh;
}

// Rank 0's tagged faces to every rank, which keeps those with a vertex in its piece: a boundary
// face of its tets, or a vertex a fixed face_tag selects. The list of the deck's tags is on every
// rank while it is sent, then each rank keeps its part (docs/loads.md#face-tags).
static void share_tagged_faces(MPI_Comm comm, const TaggedFaces& all, MeshPiece& piece) {
  int rank;
  MPI_Comm_rank(comm, &rank);
  long long n = rank == 0 ? (long long)all.size() : 0;
  MPI_Bcast(&n, 1, MPI_LONG_LONG, 0, comm);
  std::vector<int64_t> vertices = rank == 0 ? all.vertices : std::vector<int64_t>(size_t(3 * n));
  std::vector<int32_t> tags = rank == 0 ? all.tags : std::vector<int32_t>(size_t(n));
  MPI_Bcast(vertices.data(), int(3 * n), MPI_INT64_T, 0, comm);
  MPI_Bcast(tags.data(), int(n), MPI_INT32_T, 0, comm);
  std::vector<int64_t> ids = piece.mesh.vertex_ids;
  std::sort(ids.begin(), ids.end());
  TaggedFaces mine;
  std::vector<std::array<int64_t, 4>> distinct;  // (tag, vertex ids): a triangle listed twice counts once
  for (long long f = 0; f < n; ++f) distinct.push_back({tags[f], vertices[3 * f], vertices[3 * f + 1], vertices[3 * f + 2]});
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  for (const auto& d : distinct) {
    if (mine.file_counts.empty() || mine.file_counts.back().first != int32_t(d[0])) mine.file_counts.push_back({int32_t(d[0]), 0});
    ++mine.file_counts.back().second;
  }
  for (long long f = 0; f < n; ++f) {
    const int64_t* v = &vertices[3 * f];
    if (!std::binary_search(ids.begin(), ids.end(), v[0]) && !std::binary_search(ids.begin(), ids.end(), v[1]) &&
        !std::binary_search(ids.begin(), ids.end(), v[2]))
      continue;
    mine.vertices.insert(mine.vertices.end(), v, v + 3);
    mine.tags.push_back(tags[f]);
  }
  piece.mesh.tagged_faces = std::move(mine);
}

// This rank's piece of the deck's mesh: a block of a generated box or sheet, made on every rank;
// its part of a partition file; or rank 0's serial mesh, cut by METIS and sent piece by piece.
// Input errors are the same InputError on every rank.
static MeshPiece load_scene_piece(MPI_Comm comm, const SceneSpec& deck, CleanReport* repaired, const MemoryPlan& plan) {
  int rank, size;
  MPI_Comm_rank(comm, &rank);
  MPI_Comm_size(comm, &size);
  const MeshSpec& spec = deck.mesh;
  MemoryPlan own_pieces = plan;  // generated or read by each rank: no rank holds the whole mesh
  own_pieces.serial_mesh = false;
  const auto& box = spec.box_cells;
  const auto& sheet = spec.sheet_cells;
  const bool blocks = deck.bodies.empty() && spec.strands.empty() && ((spec.is_box && box_block_grid(box, size)[0] > 0) ||
                                               (spec.is_sheet && box_block_grid({sheet[0], sheet[1], 1}, size)[0] > 0));
  if (blocks) {
    const std::vector<MemoryLimit> limits = gather_memory_limits(comm);
    on_root(comm, [&] {
      if (spec.is_box) {
        check_memory(deck, int64_t(box[0] + 1) * (box[1] + 1) * (box[2] + 1), box_tets(box), with_box_mesh(own_pieces, spec),
                     limits);
        if (!deck.has_material)
          throw InputError(deck.path, 0, "material", "missing: the box has " + std::to_string(box_tets(box)) + " tetrahedra");
      } else {
        check_memory(deck, int64_t(sheet[0] + 1) * (sheet[1] + 1), 0, own_pieces, limits);
      }
    });
    MeshPiece piece;
    std::string error;
    try {
      piece = spec.is_box ? box_piece(spec.box_size, box, rank, size) : sheet_piece(spec.sheet_size, sheet, rank, size);
    } catch (const std::exception& e) {
      error = deck.path + ": mesh: " + e.what();
    }
    try {
      throw_if_any_failed(comm, error);
    } catch (const std::runtime_error& e) {
      throw InputError(e.what());
    }
    apply_transform(piece.mesh, spec.transform);
    std::array<double, 6> box = bounding_box(piece.mesh);
    for (int d = 0; d < 3; ++d) box[3 + d] = -box[3 + d];  // one MIN reduction for both corners
    MPI_Allreduce(MPI_IN_PLACE, box.data(), 6, MPI_DOUBLE, MPI_MIN, comm);
    for (int d = 0; d < 3; ++d) box[3 + d] = -box[3 + d];
    check_body_size(box, spec, deck.path, "mesh");  // the same on every rank
    if (repaired) *repaired = CleanReport();  // a generated mesh needs no repair
    return piece;
  }
  // A partition file (mesh.file, or partition: beside bodies): each rank reads its own part.
  const std::string& partition = deck.bodies.empty() ? spec.file : deck.partition_file;
  if (ends_with(partition, ".h5")) {
    const std::vector<MemoryLimit> limits = gather_memory_limits(comm);
    on_root(comm, [&] {
      if (!deck.bodies.empty() && !std::filesystem::exists(partition))
        throw InputError(deck.path, deck.partition_line, "partition",
                         "file not found: '" + partition + "' (write it with hyperqn partition " + deck.path + " -n N)");
      PartitionFileInfo info;
      try {
        info = read_partition_info(partition);
      } catch (const InputError& e) {  // a file that is not one: named by the deck's key (as mesh.file's is)
        if (deck.bodies.empty()) throw;
        throw InputError(deck.path, deck.partition_line, "partition", e.what());
      }
      if (!deck.bodies.empty()) check_bodies_partition(deck, info);
      check_memory(deck, info.vertices, info.tets, own_pieces, limits);
      if (deck.bodies.empty() && info.tets > 0 && !deck.has_material)
        throw InputError(deck.path, 0, "material", "missing: the partition file " + spec.file + " has " +
                                                       std::to_string(info.tets) + " tetrahedra");
    });
    if (repaired) *repaired = CleanReport();  // repaired when the file was written
    try {
      return read_partition_piece(comm, partition);
    } catch (const InputError& e) {  // a damaged part (the same message on every rank): named by the deck's key too
      if (deck.bodies.empty()) throw InputError(deck.path, spec.line, "mesh.file", e.what());
      throw InputError(deck.path, deck.partition_line, "partition", e.what());
    }
  }
  const TetMesh serial = load_scene_mesh(comm, deck, repaired, plan);
  MeshPiece piece;
  try {
    piece = scatter_serial_mesh(comm, serial);
  } catch (const std::runtime_error& e) {
    throw InputError(e.what());
  }
  if (!deck.face_tags().empty()) share_tagged_faces(comm, serial.tagged_faces, piece);
  return piece;
}

SceneInput load_scene_input(MPI_Comm comm, const SceneSpec& deck, const MemoryPlan& plan) {
  SceneInput in;
  in.piece = load_scene_piece(comm, deck, &in.repaired, plan);
  const TetMesh& mesh = in.piece.mesh;
  if (!deck.bodies.empty()) check_body_materials(comm, deck, in.piece);
  if (deck.bodies.empty() && deck.has_material) {  // a Medit file read for its edges may hold none
    int64_t tets = mesh.num_tets();
    MPI_Allreduce(MPI_IN_PLACE, &tets, 1, MPI_INT64_T, MPI_SUM, comm);
    if (tets == 0)
      throw InputError(deck.path, 0, "material", "the mesh " + deck.mesh.file + " has no tetrahedra for it to describe");
  }
  in.vertex_body = vertex_bodies(comm, in.piece, (int)deck.bodies.size());
  in.fixed = select_fixed_vertices(comm, mesh, deck.fixed, deck.path, in.vertex_body);
  in.rollers = std::any_of(deck.fixed.begin(), deck.fixed.end(), is_roller);
  if (in.rollers)
    in.held = select_held_components(mesh, deck.fixed, 1e-9 * mesh_diagonal(comm, mesh), in.fixed, in.vertex_body);
  // Bodies: a tet's material is its body's (its tag is the body, read_bodies_mesh); they take no regions.
  if (deck.bodies.empty()) {
    in.cell_material = select_material_regions(comm, mesh, deck.regions, deck.path);
  } else {
    const std::vector<int32_t> material_of_body = body_materials(deck.bodies).of_body;
    for (int32_t body : mesh.tet_tags) in.cell_material.push_back(material_of_body[body]);
  }
  int64_t free_vertices = 0;
  for (int32_t f : in.fixed) free_vertices += f == 0;
  MPI_Allreduce(MPI_IN_PLACE, &free_vertices, 1, MPI_INT64_T, MPI_SUM, comm);
  if (free_vertices == 0)
    throw InputError(deck.path, deck.fixed.empty() ? 0 : deck.fixed[0].line, "fixed",
                     "every vertex is fixed: nothing to simulate");
  // Only checked here: each rank selects its own attached vertices (attachment_term).
  check_attachments(comm, mesh, deck.attachments, deck.fixed, in.fixed, deck.path, in.vertex_body);
  // An activation layer thicker than the body would push every vertex near an obstacle at once.
  const double diagonal = mesh_diagonal(comm, mesh);
  for (const ContactSpec& c : {deck.contact, self_contact_spec(deck.contact, diagonal)})
    if (c.distance > diagonal) {
      char msg[200];
      std::snprintf(msg, sizeof msg, "%g is larger than the body: its rest bounding-box diagonal is %g (after mesh.transform)",
                    c.distance, diagonal);
      throw InputError(deck.path, c.distance_line, c.distance_key, msg);
    }
  // Every rank reads the obstacle files (each holds every collider): a bad one fails on all alike.
  for (size_t c = 0; c < deck.colliders.size(); ++c) make_collider(deck.colliders[c], deck.path, (int)c);
  return in;
}

bool load_scene_input_or_report(MPI_Comm comm, const SceneSpec& deck, SceneInput& input, const MemoryPlan& plan) {
  try {
    input = load_scene_input(comm, deck, plan);
    return true;
  } catch (const InputError& e) {
    print_error(comm, e.what());
    return false;
  }
}

PetscErrorCode LiveScene::setup(MPI_Comm comm, const SceneSpec& spec, SceneInput input, SceneOptions options) {
  PetscFunctionBeginUser;
  comm_ = comm;
  spec_ = &spec;
  options_ = std::move(options);
  bool releases = false;
  for (const BoxRegion& b : spec.fixed) releases = releases || b.release > 0;
  for (const AttachmentSpec& a : spec.attachments) releases = releases || a.region.release > 0;
  fracture_ = fracture_specs(spec);  // empty without material.fracture
  for (const FractureSpec& f : fracture_) fracture_resolve_ = std::max(fracture_resolve_, f.given ? f.resolve : 0);
  const bool separates = !spec.cuts.empty() || !fracture_.empty();
  snap_strains_ = snap_strains(spec);
  tear_strains_ = tear_strains(spec);
  tear_resolve_ = tear_resolve(spec);
  snap_resolve_ = snap_resolve(spec);
  cuts_cloth_ = blades_cut_cloth(spec);
  cuts_strands_ = blades_cut_strands(spec);
  const bool breaks = separates || !snap_strains_.empty() || !tear_strains_.empty();
  if (releases || breaks) kept_ = input;  // a release, cut or break rebuilds the scene from this rank's piece
  if (breaks) {  // the H0 that follows cuts, fracture, snaps and tears (docs/topology.md#h0-across-a-cut)
    PetscBool flag = PETSC_TRUE, set = PETSC_FALSE;
    PetscCall(PetscOptionsGetBool(nullptr, nullptr, "-hyperqn_topology_h0", &flag, &set));
    // TopologyH0 corrects a factor kept in double: a single-precision factor is factored again
    follow_cuts_ = (!set || flag) && options_.h0_precision == H0Precision::double_precision;
    flag = PETSC_FALSE;
    PetscCall(PetscOptionsGetBool(nullptr, nullptr, "-hyperqn_test_topology_h0_check", &flag, nullptr));
    topology_check_.check = flag;
    flag = PETSC_FALSE;
    PetscCall(PetscOptionsGetBool(nullptr, nullptr, "-hyperqn_test_topology_h0_drop_edit", &flag, nullptr));
    topology_check_.drop_edit = flag;
    PetscInt max_touched = 0;
    PetscCall(PetscOptionsGetInt(nullptr, nullptr, "-hyperqn_test_topology_h0_max_touched", &max_touched, nullptr));
    topology_check_.max_touched = max_touched;
  }
  if ((!snap_strains_.empty() || !tear_strains_.empty()) && spec.time.integrator == TimeIntegrator::implicit_midpoint)
    PetscCall(PetscPrintf(comm, "hyperqn: warning: %s: time.integrator: implicit-midpoint does not damp what a snap or a "
                                "tear sets ringing (stiff modes far above 1/h): the stored energy can grow many times "
                                "over; implicit-euler or bdf2 damp it (docs/snapping.md)\n",
                          spec.path.c_str()));
  if (breaks) {  // copies' ids come after every id of the input, the vertices cleaning dropped too
    long long slots = 0, dropped = input.repaired.dropped_vertices;  // (rank 0's)
    for (int64_t id : input.piece.mesh.vertex_ids) slots = std::max<long long>(slots, id + 1);
    MPI_Allreduce(MPI_IN_PLACE, &slots, 1, MPI_LONG_LONG, MPI_MAX, comm);
    MPI_Bcast(&dropped, 1, MPI_LONG_LONG, 0, comm);
    slots = std::max<long long>(slots, input.piece.global_vertices + dropped);  // (the last may be dropped)
    id_offset_ = slots - input.piece.global_vertices;
  }
  if (!spec.cuts.empty()) {
    // A blade whose sweep never comes near the body's rest bounding box (grown by its diagonal)
    // over the run's frames: said, not refused. A rest-frame blade meets the rest shape, so it cuts
    // nothing; a world-frame blade meets the body where it is, and a body that falls, is pushed or
    // is moved may still reach it: it cuts only if the body moves there (whether it does is the solve's).
    double lo[3], hi[3];
    bounding_box(input.piece.mesh.coords, lo, hi);
    MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, comm);
    MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, comm);
    const Eigen::Vector3d blo(lo[0], lo[1], lo[2]), bhi(hi[0], hi[1], hi[2]), grow = Eigen::Vector3d::Constant((bhi - blo).norm());
    for (size_t k = 0; k < spec.cuts.size(); ++k) {
      bool meets = false;
      for (int f = 0; f < spec.time.frames && !meets; ++f)
        meets = BladeSweep(spec.cuts[k], f * spec.time.dt, (f + 1) * spec.time.dt).may_meet_box(blo - grow, bhi + grow);
      if (!meets)
        PetscCall(PetscPrintf(comm, "hyperqn: warning: %s:%d: cuts[%zu]: the blade never comes near the body's rest position in "
                                    "the run's %d frames (it stays farther than the body's size from its rest bounding box): %s\n",
                              spec.path.c_str(), spec.cuts[k].line, k, spec.time.frames,
                              spec.cuts[k].frame == CutFrame::rest ? "it cuts nothing (frame: rest)"
                                                                   : "it cuts only if the body moves there (frame: world)"));
    }
  }
  // A release after the last step's start never happens in this run: said, not refused (a restart
  // with more frames may reach it).
  const double last_start = (spec.time.frames - 1) * spec.time.dt;
  const auto never_released = [&](const BoxRegion& b, const char* what) {
    if (!(b.release >= 0 && b.release > last_start * (1 + 1e-12))) return PetscErrorCode(0);
    char text[512];
    std::snprintf(text, sizeof text, "%s:%d: %s's release at t = %g s comes after the run's last step starts (t = %g s): "
                  "it is not released in this run", spec.path.c_str(), b.line, what, b.release, last_start);
    return PetscPrintf(comm, "hyperqn: warning: %s\n", text);
  };
  for (const BoxRegion& b : spec.fixed) PetscCall(never_released(b, "a fixed region"));
  for (const AttachmentSpec& a : spec.attachments) PetscCall(never_released(a.region, "an attachment"));
  scene_ = std::make_unique<Scene>();
  PetscCall(build(std::move(input), {}, *scene_));
  if (separates) original_boundary_ = std::make_shared<const std::vector<int64_t>>(boundary_tet_faces(scene_->mesh));  // which loads keep to after cuts (docs/loads.md)
  if (!spec.contact.self) PetscFunctionReturn(0);
  // With self-contact a fresh crack opens by its activation distance d (mesh/separation.hpp,
  // CrackOpening), the input's d whatever the cuts do to the rest shape later.
  const double d = self_contact_spec(spec.contact, rest_diagonal(scene_->mesh)).distance;
  if (separates) opening_width_ = d;
  // And a torn cloth edge by d and its thickness (mesh/cloth_separation.hpp), or the deck is refused.
  if (!tear_strains_.empty() || cuts_cloth_) tear_opening_ = tear_opening(comm, spec, kept_.piece, d);
  PetscFunctionReturn(0);
}

// Per row of the scene's vertex matrix A1 (a free vertex), its vertex id: every row's, the same on
// every rank (the rows a TopologyH0 follows across cuts; on more than one rank it lives on rank 0,
// with the gathered factor). A rank knows the ids of its own and its ghost vertices' rows, so the
// largest of every rank's entries (-1 where it knows none) is each row's id.
static PetscErrorCode row_ids(MPI_Comm comm, const DistributedMesh& mesh, std::vector<int64_t>* ids) {
  PetscFunctionBeginUser;
  ids->assign(mesh.global_dofs / 3, -1);
  for (PetscInt v = 0; v < mesh.num_vertices; ++v)
    if (mesh.global_dof[v] >= 0) (*ids)[mesh.global_dof[v] / 3] = mesh.vertex_ids[v];
  PetscMPIInt size;
  PetscCallMPI(MPI_Comm_size(comm, &size));
  if (size > 1) PetscCallMPI(MPI_Allreduce(MPI_IN_PLACE, ids->data(), (int)ids->size(), MPI_INT64_T, MPI_MAX, comm));
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::build(SceneInput input, const std::vector<char>& released_attachments, Scene& s,
                                Scene* before, bool* corrected) const {
  const SceneSpec& spec = *spec_;
  PetscFunctionBeginUser;
  PetscCall(event_begin(&LogEvents::scene));
  PetscCall(distribute_mesh(comm_, input.piece, input.fixed, input.cell_material, s.mesh));
  s.mesh.num_bodies = (int)spec.bodies.size();
  s.mesh.vertex_body = std::move(input.vertex_body);  // the DMPlex keeps the piece's vertices in order
  s.mesh.unopened_rest = input.piece.unopened;        // in the same order
  s.mesh.original_boundary = original_boundary_;     // (null at the first build: the input's mesh)
  s.mesh.rollers = input.rollers;
  if (s.mesh.rollers) {  // the free vertices' held components
    s.mesh.held.assign(3 * s.mesh.num_vertices, 0);
    for (PetscInt v = 0; v < s.mesh.num_vertices; ++v)
      if (s.mesh.fixed[v] == 0)
        for (int d = 0; d < 3; ++d) s.mesh.held[3 * v + d] = input.held[3 * v + d];
  }
  input = SceneInput();  // the piece is no longer needed
  std::vector<std::unique_ptr<EnergyTerm>> terms = scene_elastic_terms(s.mesh, spec);
  if (auto attached = attachment_term(s.mesh, spec.attachments, released_attachments)) terms.push_back(std::move(attached));
  for (auto& load : load_terms(s.mesh, spec.loads)) terms.push_back(std::move(load));
  if (options_.extra_terms) options_.extra_terms(s.mesh, terms);
  if (auto contact = contact_term(s.mesh, spec.colliders, spec.contact, spec.path, spec.bodies)) terms.push_back(std::move(contact));
  if (auto self = self_contact_term(s.mesh, spec)) terms.push_back(std::move(self));
  s.body = std::make_unique<Body>(s.mesh, std::move(terms));
  s.body->set_fixed_motion(spec.fixed);
  s.step = std::make_unique<StepObjective>(*s.body, spec.time.dt, spec.gravity, spec.time.damping,
                                                 options_.warm_start, options_.upright_guess,
                                                 options_.element_limit, spec.time.integrator, spec.time.pseudo_step);
  PetscCall(s.step->setup());
  if (!before && spec.time.pseudo_step > 0) {
    // A pseudo step far from the automatic one: g = s^2 (E - W) underflows (a step "converged" at
    // 0 iterations where nothing moved) or overflows, or M or s^2 L is lost in H0.
    double automatic;
    PetscCall(s.step->automatic_pseudo_step(&automatic));
    const double ratio = spec.time.pseudo_step / automatic;
    if (!(ratio >= StepObjective::kPseudoStepRange[0] && ratio <= StepObjective::kPseudoStepRange[1])) {
      char text[256];
      std::snprintf(text, sizeof text, "%g is %.3g times the automatic pseudo step of this mesh (%g s): give one "
                    "within [%g, %g] times it, or leave the key out", spec.time.pseudo_step, ratio, automatic,
                    StepObjective::kPseudoStepRange[0], StepObjective::kPseudoStepRange[1]);
      throw InputError(spec.path, spec.time.pseudo_step_line, "time.pseudo_step", text);
    }
  }
  PetscCall(s.body->set_masses(s.step->mass()));
  std::vector<H0> wanted;
  s.poisson_ratio = options_.poisson_ratio;
  s.weight_deflection = 0;
  if (options_.held_weight > 0 && s.mesh.global_segments == 0 && s.mesh.global_triangles == 0) {
    double lo[3], hi[3];  // over all ranks: the same at every rank count
    rest_bounding_box(s.mesh, lo, hi);
    s.weight_deflection = self_weight_deflection(options_.held_weight, lo, hi);
  }
  for (H0 h0 : {H0::laplacian, H0::rest_stiffness, H0::amg, H0::volumetric})  // in this order, each once
    if (std::any_of(options_.h0s.begin(), options_.h0s.end(), [&](H0 setting) {
          return resolved_h0(setting, s.mesh.global_cells, s.poisson_ratio, s.weight_deflection) == h0;
        }))
      wanted.push_back(h0);
  // With cuts or breaks, the supernodal factor of M + h^2 L (on one rank, or gathered to rank 0) is a
  // TopologyH0's, and a changed scene
  // follows the one before by a correction: only with one constant matrix, so that every matrix
  // of a scene was last factored at the same batch (what a restart replays from).
  std::vector<int64_t> ids;
  if (follow_cuts_) PetscCall(row_ids(comm_, s.mesh, &ids));
  FactoredSystem* followed = nullptr;
  if (before && wanted.size() == 1 && before->constant_matrices.size() == 1 && before->constant_matrices.count(wanted[0]))
    followed = before->constant_matrices.at(wanted[0]).get();
  if (corrected) *corrected = false;
  for (H0 h0 : wanted) {
    auto& matrix = s.constant_matrices[h0];
    matrix = std::make_unique<FactoredSystem>();
    const FactorPackage package = h0 == H0::amg ? FactorPackage::amg : options_.h0_package;
    if (followed && followed->follows_topology() && !ids.empty()) {
      PetscMPIInt size;
      PetscCallMPI(MPI_Comm_size(comm_, &size));
      if (size == 1) s.step->pattern_from_cells();  // create_vertex_matrix: one rank
      bool done = false;
      PetscCall(matrix->follow(*followed, *s.step, package, ids, topology_check_, &done));
      if (corrected) *corrected = done;
    } else {
      matrix->set_row_ids(ids, topology_check_.max_touched);
      PetscCall(matrix->setup(*s.step, constant_matrix_of(h0), package, options_.h0_precision));
    }
  }
  PetscCall(event_end(&LogEvents::scene));
  PetscFunctionReturn(0);
}

const FactoredSystem* Scene::constant_matrix(const SolverSpec& spec) const {
  if (!solver_uses_constant_matrix(spec.type)) return nullptr;
  const auto found = constant_matrices.find(resolved_h0(spec, mesh.global_cells, poisson_ratio, weight_deflection));
  return found == constant_matrices.end() ? nullptr : found->second.get();
}

PetscErrorCode LiveScene::initial_state(State& s) const {
  PetscFunctionBeginUser;
  PetscCall(s.create(scene_->step->layout()));
  PetscCall(scene_->body->rest_positions(s.x));
  PetscCall(apply_initial_state(spec_->initial, *scene_->body, s.x));
  PetscCall(scene_->body->hold(s.x));  // rollers: held components where their supports are
  if (!spec_->bodies.empty()) {  // each body's initial velocity
    const DistributedMesh& m = scene_->mesh;
    std::vector<double> v(3 * m.num_vertices, 0.0);
    for (PetscInt i = 0; i < m.num_vertices; ++i)
      for (int d = 0; d < 3; ++d) v[3 * i + d] = spec_->bodies[m.vertex_body[i]].velocity[d];
    PetscCall(scene_->body->free_values(v, s.v));
  }
  s.frame = 0;
  s.time = 0;
  s.released.assign(spec_->fixed.size(), 0);
  s.released_attachments.assign(spec_->attachments.size(), 0);
  PetscFunctionReturn(0);
}

// Whether the load whose check_start names `key` selects something once every fixed region with a
// release is released (the scene as it will be then, built once; only for a load refused now).
PetscErrorCode LiveScene::load_acts_after_releases(const std::string& key, bool* acts) const {
  PetscFunctionBeginUser;
  *acts = false;
  std::vector<char> released(spec_->fixed.size(), 0);
  bool any = false;
  for (size_t k = 0; k < spec_->fixed.size(); ++k) any = any || (released[k] = spec_->fixed[k].release > 0);
  if (!any) PetscFunctionReturn(0);
  std::unique_ptr<Scene> later;
  PetscCall(rebuild(released, std::vector<char>(spec_->attachments.size(), 0), later));
  *acts = true;
  for (const auto& term : later->body->terms()) {
    InputProblem problem;
    PetscCall(term->check_start(later->mesh.rest, problem));  // (at rest: the local vertices' rest positions)
    if (problem.key == key) *acts = false;
  }
  PetscFunctionReturn(0);
}

PetscErrorCode LiveScene::check_start(const State& s, bool* ok) const {
  std::vector<double> pos;
  PetscFunctionBeginUser;
  *ok = true;
  PetscCall(scene_->body->local_positions(s.x, pos));
  for (const auto& term : scene_->body->terms()) {
    InputProblem problem;
    PetscCall(term->check_start(pos, problem));
    if (problem.key.rfind("loads[", 0) == 0) {
      bool later = false;  // a load on vertices a support holds until its release acts from then
      PetscCall(load_acts_after_releases(problem.key, &later));
      if (later) continue;
    }
    if (!problem.what.empty()) {
      PetscCall(print_error(comm_, InputError(spec_->path, problem.line, problem.key, problem.what).what()));
      *ok = false;
      break;
    }
  }
  PetscFunctionReturn(0);
}

}  // namespace hyperqn
