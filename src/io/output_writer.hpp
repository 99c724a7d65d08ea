// Where a run's frames go. The simulation calls every writer the deck asked for: begin_run once,
// write_frame at each output frame (and at the last good frame when a run stops early), set_mesh
// when the scene was rebuilt (fixed regions released), end_run with the run's summary. The VTK
// series is one writer; a checkpoint or another format is another. docs/architecture.md, "Add an
// output writer".
#pragma once
#include <string>
#include <utility>
#include <vector>

#include "io/records.hpp"
#include "mesh/distributed_mesh.hpp"

namespace hyperqn {

struct State;

// A symmetric tensor's 6 values per element, in the order VTK reads a 6-component array as a
// symmetric tensor: xx, yy, zz, xy, yz, xz (value i is entry (kSymmetricRow[i], kSymmetricCol[i])).
// A third fewer bytes to write than 9 (docs/records/2026-12-02-field-output-cost.md).
constexpr int kSymmetricRow[6] = {0, 1, 2, 0, 1, 0};
constexpr int kSymmetricCol[6] = {0, 1, 2, 1, 2, 2};
template <class Matrix>
void store_symmetric(const Matrix& A, double* out) {
  for (int i = 0; i < 6; ++i) out[i] = A(kSymmetricRow[i], kSymmetricCol[i]);
}

// A per-element field the deck asked for (output.fields, terms/element_fields.hpp): its name, its
// values per element (1: a scalar, 3: a vector, 6: a symmetric 3 x 3 tensor, kSymmetricRow's
// order), and `components`
// values per local element in element_J's order (io/frame_fields.hpp; NaN: the element has none).
struct FrameElementField {
  std::string name;
  int components = 1;
  const std::vector<double>* values = nullptr;
  bool single = false;  // written rounded to 32-bit floats (output.field_precision: single): half the bytes
};

// One frame, as local arrays of this rank (positions, velocities, J already finite).
struct FrameData {
  int frame = 0;
  double time = 0;
  const State* state = nullptr;                     // the run's state (global vectors)
  const std::vector<double>* positions = nullptr;   // 3 per local vertex
  const std::vector<double>* velocities = nullptr;  // 3 per local vertex
  const std::vector<double>* J = nullptr;           // per local tet
  // The terms' point fields (EnergyTerm::point_fields, e.g. contact_force): name, 3 values per local vertex.
  std::vector<std::pair<std::string, const std::vector<double>*>> point_fields;
  std::vector<FrameElementField> element_fields;  // the deck's output.fields, in its order
};

class OutputWriter {
 public:
  virtual ~OutputWriter() = default;
  // Throw std::runtime_error if something cannot be written.
  virtual void begin_run(const DistributedMesh& /*mesh*/) {}
  virtual void write_frame(const FrameData& f) = 0;
  virtual void set_mesh(const DistributedMesh& mesh) = 0;
  virtual void end_run(const RunSummary& /*summary*/) {}
  // Restart (io/checkpoint.hpp): a writer that must remember something to continue an earlier
  // run's output names it by a key ("": nothing to remember); its state goes into each checkpoint,
  // and a restarted run hands it back to resume (frame: the checkpoint's; later frames' output goes).
  virtual std::string restart_key() const { return ""; }
  virtual std::string restart_state() const { return ""; }
  virtual void resume(const std::string& /*state*/, int /*frame*/) {}
  // Whether the series' index lists `frame` (a restart at the run's last frame writes it if not).
  virtual bool lists_frame(int /*frame*/) const { return false; }
};

}  // namespace hyperqn
