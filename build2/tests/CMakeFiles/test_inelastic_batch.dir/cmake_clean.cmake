file(REMOVE_RECURSE
  "CMakeFiles/test_inelastic_batch.dir/test_inelastic_batch.cpp.o"
  "CMakeFiles/test_inelastic_batch.dir/test_inelastic_batch.cpp.o.d"
  "test_inelastic_batch"
  "test_inelastic_batch.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_inelastic_batch.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
