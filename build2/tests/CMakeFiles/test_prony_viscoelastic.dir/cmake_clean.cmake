file(REMOVE_RECURSE
  "CMakeFiles/test_prony_viscoelastic.dir/test_prony_viscoelastic.cpp.o"
  "CMakeFiles/test_prony_viscoelastic.dir/test_prony_viscoelastic.cpp.o.d"
  "test_prony_viscoelastic"
  "test_prony_viscoelastic.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_prony_viscoelastic.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
