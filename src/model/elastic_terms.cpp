#include "model/elastic_terms.hpp"

#include <algorithm>

#include "materials/material_factory.hpp"
#include "io/log_events.hpp"
#include "model/tearing.hpp"
#include "terms/attachments.hpp"
#include "terms/cloth_bending.hpp"
#include "terms/cloth_membrane.hpp"
#include "terms/cloth_springs.hpp"
#include "terms/continuum_tets.hpp"
#include "terms/inelastic_tets.hpp"
#include "terms/element_kernels.hpp"
#include "terms/mass_spring_tets.hpp"
#include "terms/self_contact.hpp"
#include "terms/strand_segments.hpp"
#include "terms/surface_mass.hpp"

namespace hyperqn {

// The rest volume of the tets of material k (a body's, in a scene of bodies), over all ranks, before
// any crack opened (mass_rest: the total mass stays the deck's).
static double rest_volume(const DistributedMesh& mesh, int k) {
  double local = 0, volume = 0;
  for (PetscInt c = 0; c < mesh.num_cells; ++c)
    if ((mesh.cell_material.empty() ? 0 : mesh.cell_material[c]) == k)
      local += edge_matrix(mass_rest(mesh), &mesh.cells[4 * c]).determinant() / 6.0;
  MPI_Allreduce(&local, &volume, 1, MPI_DOUBLE, MPI_SUM, PetscObjectComm((PetscObject)mesh.dm));
  return volume;
}

// The tets' terms: materials[k] is the material of the tets with cell_material k.
static void add_tet_terms(const DistributedMesh& mesh, const std::vector<MaterialSpec>& materials,
                          std::vector<std::unique_ptr<EnergyTerm>>& terms) {
  if (mesh.global_cells == 0) return;
  std::vector<std::unique_ptr<Material>> continuum, equilibrium;
  std::vector<std::unique_ptr<InelasticModel>> inelastic;
  std::vector<double> stiffness, weight, density;
  bool any_continuum = false, any_springs = false;
  for (const MaterialSpec& spec : materials) {
    // A model that is not an energy density of F is the mass-spring one (material_factory.hpp).
    const bool springs = !find_material_model(spec.model)->create;
    // An inelastic material's tets are its kind's term's, its model their equilibrium part (or only
    // its elastic law's name, for a kind whose energy is the whole: plasticity).
    const InelasticKind* kind = find_inelastic_kind(spec.inelastic.kind);
    std::unique_ptr<Material> material = springs ? nullptr : make_material(spec);
    if (kind && kind->whole_energy) material = nullptr;
    inelastic.push_back(kind ? kind->create(spec) : nullptr);
    // A spring's own weight in L is its stiffness k; an inelastic model adds its own (the branches
    // their instantaneous 2 sum mu_i).
    double own = springs ? spec.spring_stiffness : material ? material->laplacian_weight() : 0.0;
    if (kind) own += inelastic.back()->laplacian_weight();
    continuum.push_back(kind ? nullptr : std::move(material));
    equilibrium.push_back(kind ? std::move(material) : nullptr);
    stiffness.push_back(springs ? spec.spring_stiffness : 0.0);
    weight.push_back(spec.laplacian_weight > 0 ? spec.laplacian_weight : own);
    const int k = (int)density.size();
    const double volume = spec.has_density ? 0.0 : rest_volume(mesh, k);
    density.push_back(spec.has_density ? spec.density : volume > 0 ? spec.total_mass / volume : 0.0);
    any_continuum = any_continuum || (!springs && !kind);
    any_springs = any_springs || springs;
  }
  if (any_continuum) terms.push_back(std::make_unique<ContinuumTets>(mesh, std::move(continuum), weight, density));
  if (any_springs) terms.push_back(std::make_unique<MassSpringTets>(mesh, stiffness, weight, density));
  // One term per inelastic kind, with its materials' models (the others' null).
  for (const InelasticKind& kind : inelastic_kinds()) {
    std::vector<std::unique_ptr<Material>> its_materials;
    std::vector<std::unique_ptr<InelasticModel>> its_models;
    bool any = false;
    for (size_t m = 0; m < materials.size(); ++m) {
      const bool its = materials[m].inelastic.kind == kind.key;
      its_materials.push_back(its ? std::move(equilibrium[m]) : nullptr);
      its_models.push_back(its ? std::move(inelastic[m]) : nullptr);
      any = any || its;
    }
    if (any)
      terms.push_back(std::make_unique<InelasticTets>(mesh, kind.state, std::move(its_materials), std::move(its_models),
                                                      weight, density));
  }
}

// The name of a yielding spring set's history (the checkpoints' key): one per body (-1: the scene's).
static std::string yield_state(const char* what, int body) {
  return std::string(what) + (body < 0 ? "" : "_body" + std::to_string(body));
}

// A cloth's terms (mass, stretching, bending) over the triangles and hinges of one body (-1: all):
// each term gets the elements it owns (body_elements), in the mesh's order.
static void add_cloth_terms(const DistributedMesh& mesh, const ClothSpec& cloth, int body,
                            std::vector<std::unique_ptr<EnergyTerm>>& terms) {
  const std::vector<PetscInt> triangles = body_elements(mesh, mesh.triangles, 3, body);
  terms.push_back(std::make_unique<SurfaceMass>(mesh, cloth.areal_density, triangles));
  if (cloth.model == ClothModel::membrane)
    terms.push_back(std::make_unique<ClothMembrane>(mesh, cloth.material, cloth.mu, cloth.lambda, triangles));
  else
    terms.push_back(std::make_unique<ClothSprings>(mesh, cloth.stretch_stiffness, triangles, cloth.yield,
                                                   yield_state("edge_yield", body)));
  if (cloth.bending != BendingModel::none && mesh.global_hinges > 0)
    terms.push_back(std::make_unique<ClothBending>(mesh, cloth.bending, cloth.bending_stiffness,
                                                   body_elements(mesh, mesh.hinges, 4, body), cloth.bending_yield,
                                                   yield_state("hinge_yield", body)));
}

std::vector<std::unique_ptr<EnergyTerm>> elastic_terms(const DistributedMesh& mesh,
                                                       const std::vector<MaterialSpec>& materials,
                                                       const StrandMaterial& strands, const ClothSpec& cloth) {
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  add_tet_terms(mesh, materials, terms);
  if (mesh.global_segments > 0)
    terms.push_back(std::make_unique<StrandSegments>(mesh, strands.axial_stiffness, strands.linear_density,
                                                     strands.laplacian_weight, body_elements(mesh, mesh.segments, 2, -1),
                                                     strands.yield, yield_state("strand_yield", -1)));
  if (mesh.global_triangles > 0) add_cloth_terms(mesh, cloth, -1, terms);
  return terms;
}

std::vector<std::unique_ptr<EnergyTerm>> body_terms(const DistributedMesh& mesh, const std::vector<BodySpec>& bodies) {
  std::vector<std::unique_ptr<EnergyTerm>> terms;
  add_tet_terms(mesh, body_materials(bodies).materials, terms);
  for (size_t k = 0; k < bodies.size(); ++k) {
    const StrandMaterial& strands = bodies[k].strand_material;
    if (bodies[k].mesh.has_strands())
      terms.push_back(std::make_unique<StrandSegments>(mesh, strands.axial_stiffness, strands.linear_density,
                                                       strands.laplacian_weight, body_elements(mesh, mesh.segments, 2, (int)k),
                                                       strands.yield, yield_state("strand_yield", (int)k)));
    if (bodies[k].mesh.has_cloth()) add_cloth_terms(mesh, bodies[k].cloth, (int)k, terms);
  }
  return terms;
}

// A deck without bodies: its tet materials as scene_elastic_terms takes them, the default one and
// then the regions'.
static std::vector<MaterialSpec> mesh_materials(const SceneSpec& spec) {
  std::vector<MaterialSpec> materials{spec.material};
  for (const MaterialRegion& r : spec.regions) materials.push_back(r.material);
  return materials;
}

// A hyperelastic tet material with no history: what the constant matrices' choice reads.
static bool plain_hyperelastic(const MaterialSpec& m) {
  const MaterialModel* model = find_material_model(m.model);
  return model && model->create && !find_inelastic_kind(m.inelastic.kind);
}

std::vector<std::unique_ptr<EnergyTerm>> scene_elastic_terms(const DistributedMesh& mesh, const SceneSpec& spec) {
  if (!spec.bodies.empty()) return body_terms(mesh, spec.bodies);
  return elastic_terms(mesh, mesh_materials(spec), spec.strand_material, spec.cloth);
}

double largest_poisson_ratio(const SceneSpec& spec) {
  const std::vector<MaterialSpec> materials = spec.bodies.empty() ? mesh_materials(spec) : body_materials(spec.bodies).materials;
  double largest = 0;
  for (const MaterialSpec& m : materials) {
    if (!plain_hyperelastic(m) || !(m.lambda + m.mu > 0)) continue;
    largest = std::max(largest, m.lambda / (2 * (m.lambda + m.mu)));
  }
  return largest;
}

double largest_density_over_modulus(const SceneSpec& spec) {
  if (!spec.bodies.empty() || !spec.has_material) return 0;
  double largest = 0;
  for (const MaterialSpec& m : mesh_materials(spec)) {
    if (!plain_hyperelastic(m) || m.fracture.given || !m.has_density || !(m.mu > 0) || !(m.lambda + m.mu > 0) ||
        !(m.density > 0))
      return 0;
    const double E = m.mu * (3 * m.lambda + 2 * m.mu) / (m.lambda + m.mu);
    if (!(E > 0)) return 0;
    largest = std::max(largest, m.density / E);
  }
  return largest;
}

std::vector<PetscInt> attached_vertices(const DistributedMesh& mesh, const AttachmentSpec& a, double tol) {
  std::vector<PetscInt> vertices;
  // Fixed vertices are left to their fixed region; ghosts to the rank that owns them.
  for (PetscInt v = 0; v < mesh.num_vertices; ++v)
    if (mesh.owned[v] && mesh.local_dof[v] >= 0 && selects(a.region, &mesh.rest[3 * v], v, mesh.vertex_body, tol))
      vertices.push_back(v);
  return vertices;
}

std::vector<std::vector<PetscInt>> attached_vertex_sets(const DistributedMesh& mesh,
                                                        const std::vector<AttachmentSpec>& attachments,
                                                        const std::vector<char>& released) {
  const double tol = 1e-9 * rest_diagonal(mesh);
  std::vector<std::vector<PetscInt>> sets(attachments.size());
  for (size_t k = 0; k < attachments.size(); ++k)
    if (k >= released.size() || !released[k]) sets[k] = attached_vertices(mesh, attachments[k], tol);
  return sets;
}

std::unique_ptr<EnergyTerm> attachment_term(const DistributedMesh& mesh, const std::vector<AttachmentSpec>& attachments,
                                            const std::vector<char>& released) {
  std::vector<std::vector<PetscInt>> sets = attached_vertex_sets(mesh, attachments, released);
  std::vector<AttachedVertices> groups;
  for (size_t k = 0; k < attachments.size(); ++k) {
    if (k < released.size() && released[k]) continue;
    AttachedVertices group;
    group.stiffness = attachments[k].stiffness;
    group.motion = attachments[k].region.motion;
    group.vertices = std::move(sets[k]);
    groups.push_back(std::move(group));
  }
  if (groups.empty()) return nullptr;
  return std::make_unique<Attachments>(mesh, std::move(groups));
}

std::unique_ptr<EnergyTerm> contact_term(const DistributedMesh& mesh, const std::vector<ColliderSpec>& colliders,
                                         const ContactSpec& contact, const std::string& deck_path,
                                         const std::vector<BodySpec>& bodies) {
  if (colliders.empty()) return nullptr;
  std::vector<std::unique_ptr<Collider>> built;
  for (size_t c = 0; c < colliders.size(); ++c) built.push_back(make_collider(colliders[c], deck_path, (int)c));
  std::vector<std::string> names;  // "bodies[1] 'ball' (deck line 12)"; the name only if the deck gave one
  for (size_t k = 0; k < bodies.size(); ++k) {
    const std::string index = std::to_string(k);
    names.push_back("bodies[" + index + "]" + (bodies[k].name == "body" + index ? "" : " '" + bodies[k].name + "'") +
                    " (deck line " + std::to_string(bodies[k].line) + ")");
  }
  return std::make_unique<ContactTerm>(mesh, std::move(built), resolved_contact(contact, rest_diagonal(mesh)),
                                       log_events().contact, std::move(names));
}

std::unique_ptr<EnergyTerm> self_contact_term(const DistributedMesh& mesh, const SceneSpec& spec) {
  if (!spec.contact.self) return nullptr;
  std::vector<SelfContactBody> bodies;
  if (spec.bodies.empty()) bodies.push_back({"", spec.mesh.has_cloth() ? spec.cloth.thickness : 0.0, spec.cloth.thickness_line});
  for (size_t k = 0; k < spec.bodies.size(); ++k) {
    const BodySpec& b = spec.bodies[k];
    bodies.push_back({"bodies[" + std::to_string(k) + "]", b.mesh.has_cloth() ? b.cloth.thickness : 0.0,
                      b.cloth.thickness_line, b.line});
  }
  std::vector<int> fixed_lines;
  for (const BoxRegion& r : spec.fixed) fixed_lines.push_back(r.line);
  ContactSpec contact = self_contact_spec(spec.contact, rest_diagonal(mesh));
  // Sides of a crack or a torn edge that could not open keep one rest position (mesh/separation.hpp)
  contact.joined_twins = !spec.cuts.empty() || !tear_strains(spec).empty();
  return std::make_unique<SelfContactTerm>(mesh, contact,
                                           log_events().self_contact, log_events().self_gather, log_events().self_pairs,
                                           std::move(bodies), std::move(fixed_lines));
}

}  // namespace hyperqn
