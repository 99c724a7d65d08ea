file(REMOVE_RECURSE
  "CMakeFiles/test_energy_term.dir/test_energy_term.cpp.o"
  "CMakeFiles/test_energy_term.dir/test_energy_term.cpp.o.d"
  "test_energy_term"
  "test_energy_term.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_energy_term.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
