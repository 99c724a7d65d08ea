// One entry of the deck's loads: list (docs/deck-scene.md#loads), as the deck reader fills it; the
// kinds of load and their terms are in terms/load_kind.hpp. No PETSc.
#pragma once
#include <map>
#include <string>

#include "params/curve.hpp"
#include "params/deck_keys.hpp"

namespace hyperqn {

// One entry of loads:. The region's keys are common to every kind; a kind's own values (a
// traction, a pressure) are kept by their key's name, declared in the kind's file (number_field, vector_field).
struct LoadSpec {
  std::string type;
  int line = 0;                         // deck line, for messages
  Array3 min{0, 0, 0}, max{0, 0, 0};    // the region: boundary faces or vertices in this box
  bool has_box = true;                  // the deck gives box (false: face_tag alone)
  // And/or the faces (vertices) of the mesh file's triangles of this tag (docs/loads.md#face-tags).
  int face_tag = 0;
  bool has_face_tag = false;
  int face_tag_line = 0;
  Array3 normal{0, 0, 0};               // faces only: rest outward normal within `angle` of it (0: any)
  double angle = 30;                    // degrees
  Curve curve;                          // the load's magnitude is its value times c(t) (none: 1)
  std::map<std::string, double> numbers;
  std::map<std::string, Array3> vectors;
  double number(const std::string& key) const { return numbers.at(key); }
  const Array3& vector(const std::string& key) const { return vectors.at(key); }
  // The factor of the load's value at time t.
  double factor(double t) const { return curve.given ? curve.value(t) : 1.0; }
};

// A kind's own keys: a number or a vec3 kept by name.
inline Field<LoadSpec, double> number_field(const std::string& key) {
  return [key](LoadSpec& s) -> double& { return s.numbers[key]; };
}
inline Field<LoadSpec, Array3> vector_field(const std::string& key) {
  return [key](LoadSpec& s) -> Array3& { return s.vectors[key]; };
}

}  // namespace hyperqn
