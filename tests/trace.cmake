# BVH + traversal tests (src/bvh, src/trace). The bunny case reads
# ../shared/scenes/bunny.obj when it exists and is skipped otherwise.
sc_add_test(test_bvh SOURCES test_bvh.c
            ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes)
sc_add_test(test_bvh_watertight SOURCES test_bvh_watertight.c)
