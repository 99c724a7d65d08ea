file(REMOVE_RECURSE
  "CMakeFiles/test_colliders.dir/test_colliders.cpp.o"
  "CMakeFiles/test_colliders.dir/test_colliders.cpp.o.d"
  "test_colliders"
  "test_colliders.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_colliders.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
