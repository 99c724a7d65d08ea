file(REMOVE_RECURSE
  "libhyperqn_base.a"
)
