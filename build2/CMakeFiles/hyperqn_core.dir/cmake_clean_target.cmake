file(REMOVE_RECURSE
  "libhyperqn_core.a"
)
