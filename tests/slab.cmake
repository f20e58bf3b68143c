# The BVH node (slab) test's padding (sc_ray_precompute, src/trace/ray_setup.h)
# against MPFR: per-plane bounds and whole node tests on rays through
# corners, edges and faces; MPFR comes with spherecull_reference.
sc_add_test(test_slab SOURCES test_slab.c FTZ)
