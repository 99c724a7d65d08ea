
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/wt-fracture/src/geometry/analytic_colliders.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/analytic_colliders.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/analytic_colliders.cpp.o.d"
  "/work/wt-fracture/src/geometry/blade.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/blade.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/blade.cpp.o.d"
  "/work/wt-fracture/src/geometry/bvh.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/bvh.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/bvh.cpp.o.d"
  "/work/wt-fracture/src/geometry/collider.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/collider.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/collider.cpp.o.d"
  "/work/wt-fracture/src/geometry/motion.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/motion.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/motion.cpp.o.d"
  "/work/wt-fracture/src/geometry/pair_ccd.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/pair_ccd.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/pair_ccd.cpp.o.d"
  "/work/wt-fracture/src/geometry/pair_distance.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/pair_distance.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/pair_distance.cpp.o.d"
  "/work/wt-fracture/src/geometry/surface_file.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/surface_file.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/surface_file.cpp.o.d"
  "/work/wt-fracture/src/geometry/triangle_intersection.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_intersection.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_intersection.cpp.o.d"
  "/work/wt-fracture/src/geometry/triangle_mesh_collider.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_mesh_collider.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_mesh_collider.cpp.o.d"
  "/work/wt-fracture/src/geometry/triangle_queries.cpp" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_queries.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/geometry/triangle_queries.cpp.o.d"
  "/work/wt-fracture/src/io/base64.cpp" "CMakeFiles/hyperqn_base.dir/src/io/base64.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/io/base64.cpp.o.d"
  "/work/wt-fracture/src/materials/corotated.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/corotated.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/corotated.cpp.o.d"
  "/work/wt-fracture/src/materials/fiber.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/fiber.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/fiber.cpp.o.d"
  "/work/wt-fracture/src/materials/hinge_bending.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/hinge_bending.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/hinge_bending.cpp.o.d"
  "/work/wt-fracture/src/materials/log_strain_plasticity.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/log_strain_plasticity.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/log_strain_plasticity.cpp.o.d"
  "/work/wt-fracture/src/materials/material_factory.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/material_factory.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/material_factory.cpp.o.d"
  "/work/wt-fracture/src/materials/maxwell_branches.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/maxwell_branches.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/maxwell_branches.cpp.o.d"
  "/work/wt-fracture/src/materials/membrane.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/membrane.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/membrane.cpp.o.d"
  "/work/wt-fracture/src/materials/neohookean.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/neohookean.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/neohookean.cpp.o.d"
  "/work/wt-fracture/src/materials/principal_stretch.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/principal_stretch.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/principal_stretch.cpp.o.d"
  "/work/wt-fracture/src/materials/prony_viscoelastic.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/prony_viscoelastic.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/prony_viscoelastic.cpp.o.d"
  "/work/wt-fracture/src/materials/scalar_function.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/scalar_function.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/scalar_function.cpp.o.d"
  "/work/wt-fracture/src/materials/stvk.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/stvk.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/stvk.cpp.o.d"
  "/work/wt-fracture/src/materials/tet_springs.cpp" "CMakeFiles/hyperqn_base.dir/src/materials/tet_springs.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/materials/tet_springs.cpp.o.d"
  "/work/wt-fracture/src/mesh/mesh.cpp" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh.cpp.o.d"
  "/work/wt-fracture/src/mesh/mesh_gmsh.cpp" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh_gmsh.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh_gmsh.cpp.o.d"
  "/work/wt-fracture/src/mesh/mesh_piece.cpp" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh_piece.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/mesh/mesh_piece.cpp.o.d"
  "/work/wt-fracture/src/mesh/text_tokens.cpp" "CMakeFiles/hyperqn_base.dir/src/mesh/text_tokens.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/mesh/text_tokens.cpp.o.d"
  "/work/wt-fracture/src/params/curve.cpp" "CMakeFiles/hyperqn_base.dir/src/params/curve.cpp.o" "gcc" "CMakeFiles/hyperqn_base.dir/src/params/curve.cpp.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
