// Checkpoints: the state of a run in one HDF5 file (PETSc's HDF5 viewer), from which
// `hyperqn DECK --restart PATH|latest` continues it exactly (docs/outputs.md#checkpoints).
// The file format is defined here and only here.
//
// OUTDIR/checkpoints/checkpoint_<frame>.h5 holds
//  - datasets "positions" and "velocities": (slots, 3) doubles in vertex-id order (row i = the
//    vertex with vertex_id i in the input mesh; rows of ids that cleaning dropped are 0), every
//    vertex, fixed ones included: their prescribed position and velocity at the checkpoint's
//    time (Body::set_time makes a fixed vertex's velocity the mean over the last step, which a
//    fresh Body cannot know). The order does not depend on the partition, so a checkpoint written
//    at N ranks restarts at M.
//  - attributes of the root group: format_version, physics (one "section hash" line per physics
//    section of the deck), mesh_hash, vertices, dofs, vertex_slots, ranks, frame, time, body_time,
//    released, released_attachments, started_inverted, the run's counters so far (summary_*), and
//    each output writer's restart state (writer_<key>).
#pragma once
#include <petscsys.h>

#include <string>
#include <utility>
#include <vector>

#include "io/records.hpp"
#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

struct CheckpointHeader {
  static constexpr int kVersion = 1;
  int version = kVersion;
  std::string physics;    // "section hash" lines (physics_fingerprint)
  std::string mesh_hash;  // of the serial mesh as read (rest positions and elements)
  long long vertices = 0, dofs = 0, vertex_slots = 0;  // dofs of the scene at `frame` (releases free more)
  int ranks = 0, frame = 0;
  double time = 0;       // frame * dt
  double body_time = 0;  // the time of the fixed vertices' prescribed motion (after sub-steps: the last one's)
  std::vector<char> released, released_attachments;
  int started_inverted = 0;  // the run started with inverted elements (judged by its last frame only)
  RunSummary summary;        // the counters of frames 1..frame and the work done so far
  std::vector<std::pair<std::string, std::string>> writers;  // output writer's key -> its restart state
};

// FNV-1a 64-bit of text, as 16 hex digits: the same on every machine and rank count.
std::string text_hash(const std::string& text);
// "section hash" lines from (section, canonical text) pairs.
std::string physics_fingerprint(const std::vector<std::pair<std::string, std::string>>& sections);

// Why a run of `now` cannot continue from `saved`, or "" (physics, mesh, and the vertex counts
// once now has them: now.vertices > 0).
std::string checkpoint_mismatch(const CheckpointHeader& saved, const CheckpointHeader& now);

// Writes checkpoint_<frame>.h5 in dir (created if needed) through a temporary name, renamed by
// rank 0 once every rank has closed it, so the name appears only when the file is complete; then
// keeps the newest `keep` checkpoints. pos, vel: 3 per local vertex (fixed ones: prescribed).
// Collective. *path: the file written.
PetscErrorCode write_checkpoint(MPI_Comm comm, const std::string& dir, const CheckpointHeader& h,
                                const DistributedMesh& mesh, const std::vector<double>& pos,
                                const std::vector<double>& vel, int keep, std::string* path);

// The attributes of a checkpoint (collective). Throws std::runtime_error naming the file if it is
// not a readable checkpoint.
CheckpointHeader read_checkpoint_header(MPI_Comm comm, const std::string& path);
// Positions and velocities of mesh's local vertices (3 each) from a checkpoint (collective).
PetscErrorCode read_checkpoint_vertices(MPI_Comm comm, const std::string& path, const DistributedMesh& mesh,
                                        long long vertex_slots, std::vector<double>& pos, std::vector<double>& vel);

// The newest complete checkpoint in dir (highest frame), or "" (same answer on every rank).
std::string latest_checkpoint(MPI_Comm comm, const std::string& dir);
// Frame of a checkpoint file name checkpoint_<frame>.h5, or -1.
int checkpoint_frame(const std::string& filename);
// Removes the checkpoints of frames after `frame` (a restart abandons that future) and leftover
// temporary files (rank 0; collective).
void remove_checkpoints_after(MPI_Comm comm, const std::string& dir, int frame);

// Restart: the counters of the frames already done (frames, iterations, flagged frames, ...) from
// a checkpoint's summary into s; the work done (times, factorizations, solves) is added at the end
// by add_earlier_work, so that summary.json covers the whole run.
void restore_frame_counters(RunSummary& s, const RunSummary& saved);
void add_earlier_work(RunSummary& s, const RunSummary& earlier);

}  // namespace hyperqn
