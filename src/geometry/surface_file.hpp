// Triangle surfaces of obstacles from files: Wavefront OBJ (.obj) and Medit (.mesh, its
// Triangles section). Only positions and triangles are kept.
#pragma once
#include <Eigen/Dense>
#include <array>
#include <string>
#include <vector>

namespace hyperqn {

struct TriangleSurface {
  std::vector<Eigen::Vector3d> vertices;
  std::vector<std::array<int, 3>> triangles;  // 0-based, counter-clockwise seen from outside
  std::vector<int> triangle_lines;            // per triangle: its line in the file (a polygon's fan: the f line)
};

// Reads the surface; the format is chosen by the extension (case-insensitive). Throws
// InputError naming the file (and the line of bad content) for an unknown extension, an
// unreadable file, a bad number or a vertex index out of range. A file with no triangle is
// returned as such: the caller decides how to report it.
TriangleSurface read_triangle_surface(const std::string& path);

// The two readers on text already in memory (path only names the file in errors).
TriangleSurface parse_obj(const std::string& path, const std::string& text);
TriangleSurface parse_medit_surface(const std::string& path, const std::string& text);

}  // namespace hyperqn
