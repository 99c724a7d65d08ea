
# Consider dependencies only in project.
set(CMAKE_DEPENDS_IN_PROJECT_ONLY OFF)

# The set of languages for which implicit dependencies are needed:
set(CMAKE_DEPENDS_LANGUAGES
  )

# The set of dependency files which are needed:
set(CMAKE_DEPENDS_DEPENDENCY_FILES
  "/work/wt-fracture/tests/test_deck.cpp" "tests/CMakeFiles/test_deck.dir/test_deck.cpp.o" "gcc" "tests/CMakeFiles/test_deck.dir/test_deck.cpp.o.d"
  )

# Targets to which this target links.
set(CMAKE_TARGET_LINKED_INFO_FILES
  "/work/wt-fracture/build2/CMakeFiles/hyperqn_base.dir/DependInfo.cmake"
  "/work/wt-fracture/build2/CMakeFiles/hyperqn_core.dir/DependInfo.cmake"
  )

# Fortran module output directory.
set(CMAKE_Fortran_TARGET_MODULE_DIR "")
