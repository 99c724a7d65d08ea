file(REMOVE_RECURSE
  "CMakeFiles/hyperqn.dir/src/app/main.cpp.o"
  "CMakeFiles/hyperqn.dir/src/app/main.cpp.o.d"
  "hyperqn"
  "hyperqn.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/hyperqn.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
