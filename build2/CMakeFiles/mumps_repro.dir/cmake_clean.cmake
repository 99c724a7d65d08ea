file(REMOVE_RECURSE
  "CMakeFiles/mumps_repro.dir/bench/mumps_repro.cpp.o"
  "CMakeFiles/mumps_repro.dir/bench/mumps_repro.cpp.o.d"
  "mumps_repro"
  "mumps_repro.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/mumps_repro.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
