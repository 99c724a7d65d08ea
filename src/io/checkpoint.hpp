// Checkpoints: the state of a run in one HDF5 file, from which `hyperqn DECK --restart
// PATH|latest|auto` continues it exactly (docs/outputs.md#checkpoints). The file format is
// defined here and only here; which checkpoints of a directory a restart may use is
// io/checkpoint_store.hpp's business.
//
// OUTDIR/checkpoints/checkpoint_<frame>.h5 holds, every item a dataset with HDF5's Fletcher32
// checksum (io/hdf5_file.hpp), so that a damaged file is found out when it is read:
//  - "positions" and "velocities" (and, for an integrator that keeps a history, "previous_positions"
//    and "previous_velocities": x_{n-1}, v_{n-1}; header key history 1): (slots, 3) doubles in vertex-id order (row i = the vertex with
//    vertex_id i in the input mesh; rows of ids that cleaning dropped are 0), every vertex, fixed
//    ones included: their prescribed position and velocity at the checkpoint's time
//    (Body::set_time makes a fixed vertex's velocity the mean over the last step, which a fresh
//    Body cannot know). The order does not depend on the partition, so a checkpoint written at N
//    ranks restarts at M.
//  - "header": text, one "key value" line each: format_version, run_id, run_started, deck,
//    mesh_hash, vertices, dofs, vertex_slots, ranks, frame, time, body_time, released,
//    released_attachments, cuts, cuts_factored, cut_batches, cuts_resolved and changes_decided (scripted cuts, fracture), breaks, breaks_factored and break_batches (snapped strands, torn or cut cloth, cut strands), started_inverted, writers, history, substep_halvings, substep_kept, substep_hold and
//    substep_trying (State's SubstepMemory), each dataset's checksum
//    (<name>_hash), and the run's counters so far (summary_*).
//  - "elements_<name>" for each term's per-element state (terms/element_state.hpp), as the header
//    key element_sets lists them ("name width slots hash" each): (slots, width) doubles, row i =
//    the element of global id i (rows no element has are 0). Like the vertices' order, the ids'
//    does not depend on the partition.
//  - "physics" (one "section hash" line per physics section of the deck), "flagged_frames",
//    "inverted_frames", and each output writer's restart state ("writer_<key>"): texts that grow
//    with the run, as datasets (an HDF5 attribute is limited to 64 KiB).
#pragma once
#include <petscsys.h>

#include <array>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "io/records.hpp"
#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

// The per-vertex datasets, in the order of VertexRows: the first two always, the history's two
// where the header says history 1.
inline constexpr const char* kVertexSets[] = {"positions", "velocities", "previous_positions", "previous_velocities"};
// Their values, 3 per local vertex (fixed vertices: prescribed), one vector per dataset: 2, or 4
// with the history.
using VertexRows = std::vector<std::vector<double>>;

// One term's per-element values as plain rows (io knows no term): `width` values per local
// element, keyed by the element's global id.
struct ElementRows {
  std::string name;             // the term's key for them (ElementState::name)
  int width = 0;                // values per element
  std::vector<int64_t> ids;     // this rank's elements' global ids
  std::vector<double> values;   // width per element, in ids' order
};
// What the header says of one element set: its name, width, rows in the file and checksum.
struct ElementSetInfo {
  std::string name;
  int width = 0;
  long long slots = 0;
  std::string hash;
};

struct CheckpointHeader {
  static constexpr int kVersion = 3;  // 3: the mesh hash sums per-element hashes (any rank count)
  int version = kVersion;
  // Whose it is: the run's id (summary.json's run_id; a restart keeps it), when the run's first
  // part started (UTC, ISO 8601) and its deck, for messages about a checkpoint of another run.
  std::string run_id, run_started, deck;
  std::string physics;    // "section hash" lines (physics_fingerprint)
  std::string mesh_hash;  // of the serial mesh as read (rest positions and elements)
  long long vertices = 0, dofs = 0, vertex_slots = 0;  // dofs of the scene at `frame` (releases free more)
  int ranks = 0, frame = 0;
  double time = 0;       // frame * dt
  double body_time = 0;  // the time of the fixed vertices' prescribed motion (after sub-steps: the last one's)
  std::vector<char> released, released_attachments;
  // Scripted cuts: every face separated so far, (frame, tet, tet) in order, a removed tet t as
  // (frame, t, t) (LiveScene::cut_history; header key cuts, absent without any), replayed by a restart.
  std::vector<std::array<int64_t, 3>> cuts;
  // Of them, the batches (steps) in the scene whose constant matrix was last factored (header key
  // cuts_factored; later batches were followed by TopologyH0's corrections, which a restart
  // replays from that scene; -1, absent: all).
  long long cuts_factored = -1;
  // The faces of each batch of cuts (LiveScene::cut_batches; header key cut_batches; absent: a batch
  // per frame, as before fracture's re-solves), and the re-solves of the step after `frame` that a
  // signal gave up (LiveScene::resolved_after; header key cuts_resolved, absent: 0).
  std::vector<int64_t> cut_batches;
  long long cuts_resolved = 0;
  // The changes after `frame` (cut_due, snap_due) are in, decided (a signal gave up the next frame:
  // LiveScene::changes_decided_after; header key changes_decided, absent: not).
  bool changes_decided = false;
  // Breaks: every strand segment snapped so far, (frame, kind, element) in order
  // (LiveScene::break_history; header key breaks, absent without any), replayed by a restart.
  std::vector<std::array<int64_t, 3>> breaks;
  // Of them, the batches (frames) in the scene whose constant matrix was last factored (header key
  // breaks_factored, as cuts_factored; -1, absent: all).
  long long breaks_factored = -1;
  // The breaks of each batch (LiveScene::break_batches; header key break_batches; absent: a batch
  // per frame, as before a frame could hold a blade's batch and a tear's).
  std::vector<int64_t> break_batches;
  int started_inverted = 0;  // the run started with inverted elements (judged by its last frame only)
  RunSummary summary;        // the counters of frames 1..frame and the work done so far
  std::vector<std::pair<std::string, std::string>> writers;  // output writer's key -> its restart state
  int history = 0;  // 1: the integrator's history is stored (previous_positions, previous_velocities)
  // Where the fallback chain starts the next frame: State's SubstepMemory (model/substep_memory.hpp).
  int substep_halvings = 0, substep_kept = 0, substep_hold = 1, substep_trying = 0;
  // Checksums of each dataset's values in row order (kVertexSets' order), written with them and
  // checked on every read: HDF5's own checksums guard the chunks and metadata, this guards what
  // they hold.
  std::vector<std::string> hashes;
  // The terms' element sets (write_checkpoint fills slots and hash; none: the key is absent).
  std::vector<ElementSetInfo> element_sets;
  size_t vertex_sets() const { return history ? 4 : 2; }
};

// FNV-1a 64-bit of text, as 16 hex digits: the same on every machine and rank count.
std::string text_hash(const std::string& text);
// "section hash" lines from (section, canonical text) pairs.
std::string physics_fingerprint(const std::vector<std::pair<std::string, std::string>>& sections);

// Why a run of `now` cannot continue from `saved`, or "" (physics, mesh, and the vertex counts
// once now has them: now.vertices > 0).
std::string checkpoint_mismatch(const CheckpointHeader& saved, const CheckpointHeader& now);

// Writes the checkpoint file `path` through a temporary beside it, renamed once complete, so the
// name appears only for a whole file. rows: h.vertex_sets() of them; elements: every term's
// element state (the header's element_sets are made from them).
// Collective; rank 0 alone writes the file and the others send it their rows, so a failure is one
// rank's and no rank can be left waiting inside HDF5. Throws std::runtime_error on every rank
// ("cannot write PATH: <reason>"), removing the temporary.
PetscErrorCode write_checkpoint(MPI_Comm comm, const std::string& path, const CheckpointHeader& h,
                                const DistributedMesh& mesh, const VertexRows& rows,
                                const std::vector<ElementRows>& elements = {});

// Rank 0 alone: reads the header of path and, with `data`, every row of its datasets, so that each
// checksum is checked. Returns "" for a whole checkpoint of this format (its header in *header),
// else why not.
std::string inspect_checkpoint(const std::string& path, CheckpointHeader* header, bool data = true);

// Rank 0's header, on every rank (collective).
CheckpointHeader broadcast_header(MPI_Comm comm, const CheckpointHeader& header);

// The datasets of mesh's local vertices (h.vertex_sets() of them) from a checkpoint whose header is h
// (collective: rank 0 reads and checks them, each rank receives its rows). Throws
// std::runtime_error on every rank if path cannot be read or its values are not the header's.
PetscErrorCode read_checkpoint_vertices(MPI_Comm comm, const std::string& path, const DistributedMesh& mesh,
                                        const CheckpointHeader& h, VertexRows& rows);

// The values of the scene's element sets (each with its name, width and local ids set) from a
// checkpoint whose header is h (collective). Throws std::runtime_error on every rank if the
// checkpoint's sets are not the scene's (names, widths, an id beyond its rows) or cannot be read.
PetscErrorCode read_checkpoint_elements(MPI_Comm comm, const std::string& path, const CheckpointHeader& h,
                                        std::vector<ElementRows>& elements);

// Frame of a checkpoint file name checkpoint_<frame>.h5, or -1; and the name of a frame's file.
int checkpoint_frame(const std::string& filename);
std::string checkpoint_name(int frame);

// Restart: the counters of the frames already done (frames, iterations, flagged frames, ...) from
// a checkpoint's summary into s; the work done (times, factorizations, solves) is added at the end
// by add_earlier_work, so that summary.json covers the whole run.
void restore_frame_counters(RunSummary& s, const RunSummary& saved);
void add_earlier_work(RunSummary& s, const RunSummary& earlier);

}  // namespace hyperqn
