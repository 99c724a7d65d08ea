# CMake generated Testfile for 
# Source directory: /work/wt-fracture
# Build directory: /work/wt-fracture/build2
# 
# This file includes the relevant testing commands required for 
# testing this directory and lists subdirectories to be tested as well.
subdirs("tests")
