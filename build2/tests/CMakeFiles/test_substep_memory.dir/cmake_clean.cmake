file(REMOVE_RECURSE
  "CMakeFiles/test_substep_memory.dir/test_substep_memory.cpp.o"
  "CMakeFiles/test_substep_memory.dir/test_substep_memory.cpp.o.d"
  "test_substep_memory"
  "test_substep_memory.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_substep_memory.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
