file(REMOVE_RECURSE
  "CMakeFiles/cholmod_updown.dir/bench/cholmod_updown.cpp.o"
  "CMakeFiles/cholmod_updown.dir/bench/cholmod_updown.cpp.o.d"
  "cholmod_updown"
  "cholmod_updown.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/cholmod_updown.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
