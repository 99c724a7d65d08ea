// The energy terms of a scene, from its description: the elastic ones from its materials
// (continuum tets, one term for every hyperelastic material; mass-spring tets, strand segments,
// cloth: mass, stretching, bending), the attachments and contact; only those the scene uses.
#pragma once
#include <memory>
#include <vector>

#include "mesh/distributed_mesh.hpp"
#include "model/material_spec.hpp"
#include "model/regions.hpp"
#include "model/scene_spec.hpp"
#include "terms/contact.hpp"
#include "terms/energy_term.hpp"

namespace hyperqn {

// materials[0] is the default material, materials[k + 1] that of material region k
// (mesh.cell_material says which tet has which); strands is the material of every segment.
// A material given by total_mass spreads it evenly over the rest volume of its own tets (a body's
// tets, in a scene of bodies; regions need density). cloth is the material of the triangles.
std::vector<std::unique_ptr<EnergyTerm>> elastic_terms(const DistributedMesh& mesh,
                                                       const std::vector<MaterialSpec>& materials,
                                                       const StrandMaterial& strands, const ClothSpec& cloth = {});

// The elastic terms of a scene of bodies: the tets with their bodies' materials (body_materials;
// mesh.cell_material), each body's own strand term over its segments and cloth terms over its
// triangles and hinges.
std::vector<std::unique_ptr<EnergyTerm>> body_terms(const DistributedMesh& mesh, const std::vector<BodySpec>& bodies);

// The scene's elastic terms as the spec says: elastic_terms with the default material and the
// material regions', or body_terms for a scene of bodies.
std::vector<std::unique_ptr<EnergyTerm>> scene_elastic_terms(const DistributedMesh& mesh, const SceneSpec& spec);

// The largest Poisson ratio lambda / (2 (lambda + mu)) of the scene's hyperelastic tet materials (the
// default one, the regions' or the bodies'; not mass-spring or inelastic ones, whose tets the
// volumetric H0 gives their L), from the Lame parameters the deck gives; 0 if none. solver.h0: auto
// reads it (resolved_h0).
double largest_poisson_ratio(const SceneSpec& spec);

// The largest density over Young's modulus rho / E (s^2/m^2) of the scene's tet materials (without
// bodies: the default one and the regions'), E = mu (3 lambda + 2 mu) / (lambda + mu) from the Lame
// parameters; 0 when a material is not a plain hyperelastic one with a density (springs, an
// inelastic block, fracture, a total_mass), or the mesh may hold strands or a cloth: solver.h0:
// auto reads it through held_still_weight (resolved_h0).
double largest_density_over_modulus(const SceneSpec& spec);

// The vertices attachment `a` holds on this rank: the free vertices it owns in its box (in_box with
// tolerance tol, 1e-9 of rest_diagonal(mesh), so the springs do not depend on the rank count).
std::vector<PetscInt> attached_vertices(const DistributedMesh& mesh, const AttachmentSpec& a, double tol);

// Per attachment, attached_vertices with that tolerance; none for a released one (released[k] != 0,
// or past released's end: not released). Collective (rest_diagonal).
std::vector<std::vector<PetscInt>> attached_vertex_sets(const DistributedMesh& mesh,
                                                        const std::vector<AttachmentSpec>& attachments,
                                                        const std::vector<char>& released);

// The springs of the attachments not released (released[k] != 0: attachments[k] is gone), on
// the free vertices this rank owns in each box (in_box with the serial selection's tolerance, so
// the springs do not depend on the rank count); null if none is left. Collective.
std::unique_ptr<EnergyTerm> attachment_term(const DistributedMesh& mesh, const std::vector<AttachmentSpec>& attachments,
                                            const std::vector<char>& released);

// Contact with the colliders (their files read again on every rank; deck_path names errors), its
// defaults resolved for the mesh's rest diagonal; null without colliders (no contact code at all).
// bodies: the deck's (empty: one body), which its start check names.
std::unique_ptr<EnergyTerm> contact_term(const DistributedMesh& mesh, const std::vector<ColliderSpec>& colliders,
                                         const ContactSpec& contact, const std::string& deck_path,
                                         const std::vector<BodySpec>& bodies = {});

// Self-contact of the surfaces of all bodies and cloths (terms/self_contact.hpp) with the contact
// section's model, its defaults resolved for the mesh's rest diagonal, each cloth's thickness and
// the fixed regions' deck lines (they name a region whose motion it refuses); null unless
// contact.self (no self-contact code at all). Collective.
std::unique_ptr<EnergyTerm> self_contact_term(const DistributedMesh& mesh, const SceneSpec& spec);

}  // namespace hyperqn
