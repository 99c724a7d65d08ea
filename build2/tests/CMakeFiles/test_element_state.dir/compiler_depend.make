# Empty compiler generated dependencies file for test_element_state.
# This may be replaced when dependencies are built.
