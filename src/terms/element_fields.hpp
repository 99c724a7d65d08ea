// The per-element fields of the output frames that a deck may ask for (output.fields,
// docs/outputs.md#element-fields): each field's name, its values per element, and the elements
// that have it. The terms that hold those elements compute them (EnergyTerm::element_fields,
// fill_element_fields) from their energy's own kernels, at output frames only; a deck that asks
// for none runs none of this.
#pragma once
#include <string>
#include <vector>

#include "io/output_writer.hpp"  // kSymmetricRow: the order of a symmetric tensor's values

namespace hyperqn {

enum class ElementField { cauchy_stress, von_mises, principal_stretches, green_strain, energy_density, axial_force,
                          membrane_stress, dissipated_energy, viscous_strain, equivalent_plastic_strain };

struct ElementFieldInfo {
  const char* name;      // as the deck and the files name it
  int components;        // values per element: 1 a scalar, 3 a vector, 6 a symmetric 3 x 3 tensor (kSymmetricRow's order)
  const char* elements;  // the elements that have it, for the deck's error when the scene has none
};

// In the enum's order.
inline const std::vector<ElementFieldInfo>& element_field_infos() {
  static const std::vector<ElementFieldInfo> infos = {
      {"cauchy_stress", 6, "tets"},
      {"von_mises", 1, "tets"},
      {"principal_stretches", 3, "tets"},
      {"green_strain", 6, "tets"},
      {"energy_density", 1, "tets"},
      {"axial_force", 1, "strand segments"},
      {"membrane_stress", 6,
       "cloth triangles of the membrane model (cloth.model: membrane; a mass-spring cloth's edge springs have no membrane stress)"},
      {"dissipated_energy", 1, "tets of inelastic materials (material.viscoelastic, material.plastic)"},
      {"viscous_strain", 1, "tets of viscoelastic materials (material.viscoelastic)"},
      {"equivalent_plastic_strain", 1, "tets of plastic materials (material.plastic)"},
  };
  return infos;
}
inline const ElementFieldInfo& field_info(ElementField f) { return element_field_infos()[size_t(f)]; }

inline std::vector<std::string> element_field_names() {
  std::vector<std::string> names;
  for (const ElementFieldInfo& i : element_field_infos()) names.push_back(i.name);
  return names;
}

// One asked-for field on this rank: field_info(field).components values per local element of the mesh,
// tets, then strand segments, then cloth triangles (io/frame_fields.hpp's element_J order); NaN at
// the elements no term fills.
struct ElementFieldValues {
  ElementField field;
  std::vector<double> values;
};

}  // namespace hyperqn
