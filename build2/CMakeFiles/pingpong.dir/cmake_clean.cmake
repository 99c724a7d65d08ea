file(REMOVE_RECURSE
  "CMakeFiles/pingpong.dir/bench/pingpong.c.o"
  "CMakeFiles/pingpong.dir/bench/pingpong.c.o.d"
  "pingpong"
  "pingpong.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang C)
  include(CMakeFiles/pingpong.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
