// The deck's section readers (app/deck_sections.cpp), one per section, called by the deck's top
// level (app/deck.cpp) in the deck's reading order.
#pragma once
#include <string>
#include <vector>

#include "app/deck.hpp"
#include "app/deck_reader.hpp"

namespace hyperqn::deck_reading {

// bodies[k].fixed and bodies[k].attachments: (k, the list), read after the scene's own.
struct BodyRegions {
  std::vector<std::pair<int, Value>> fixed, attachments;
};

// A curve's map (params/curve.hpp: curve_keys()) into c, given: its type's keys, end > start for a
// ramp, a table's points or its file (resolved against the deck's directory and read) and their
// checks, each error naming the deck line and key (and the file's line).
void read_curve(const Reader& r, const Value& v, Curve& c);
void read_mesh(const Reader& r, const Value& v, const fs::path& deck_dir, MeshSpec& m);
void read_strand_material(const Reader& r, const Value& v, StrandMaterial& m);
void read_cloth(const Reader& r, const Value& v, ClothSpec& c);
// The keys, ranges and models of material_keys() (from the material registry), then the rules
// that involve several keys, then the model's own checks.
void read_material(const Reader& r, const Value& v, MaterialSpec& m);
// body >= 0: bodies[body].fixed, which selects that body's vertices only.
void read_fixed(const Reader& r, const Value& v, std::vector<BoxRegion>& fixed, int body = -1);
// bodies: a list of bodies, each with its mesh, the material of each of its parts, and its own
// fixed regions and attachments (returned in regions, read after the scene's).
void read_bodies(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck, BodyRegions& regions);
// partition: the file `hyperqn partition` writes of the joined bodies.
void read_bodies_partition(const Reader& r, const Value& v, const fs::path& deck_dir, Deck& deck);
void read_colliders(const Reader& r, const Value& v, const fs::path& deck_dir, std::vector<ColliderSpec>& colliders);
void read_contact(const Reader& r, const Value& v, ContactSpec& c);
void read_attachments(const Reader& r, const Value& v, std::vector<AttachmentSpec>& attachments);
void read_loads(const Reader& r, const Value& v, std::vector<LoadSpec>& loads);
void read_cuts(const Reader& r, const Value& v, std::vector<CutSpec>& cuts);
// Each body's own fixed regions and attachments (BoxRegion::body), after the scene's.
void read_body_regions(const Reader& r, const BodyRegions& regions, Deck& deck);
void read_initial(const Reader& r, const Value& v, InitialSpec& in);
void read_regions(const Reader& r, const Value& v, const MaterialSpec& base, std::vector<MaterialRegion>& regions);
void read_time(const Reader& r, const Value& v, TimeSpec& t);
void read_solver(const Reader& r, const Value& v, SolverSpec& sv);
void read_study(const Reader& r, const Value& v, int scene_frames, StudySpec& st);
void read_output(const Reader& r, const Value& v, OutputSpec& o);
void read_checkpoint(const Reader& r, const Value& v, CheckpointSpec& c);
void read_guardrails(const Reader& r, const Value& v, GuardrailSpec& g);
// petsc: {a: {b: 1}} -> ("-a_b", "1").
void read_petsc(const Reader& r, const Value& v, const std::string& prefix, Deck& deck, int depth = 0);

}  // namespace hyperqn::deck_reading
