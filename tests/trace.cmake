# BVH + traversal tests (src/bvh, src/trace). The bunny case reads
# ../shared/scenes/bunny.obj when it exists and is skipped otherwise.
sc_add_test(test_bvh SOURCES test_bvh.c
            ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes FTZ)
sc_add_test(test_bvh_watertight SOURCES test_bvh_watertight.c FTZ)
# The high quality's triangle cut (src/bvh/split_triangle.h) against MPFR.
sc_add_test(test_split_triangle SOURCES test_split_triangle.c FTZ)

# Prefilter modes never change an answer, on every shipped and shared scene.
if(TARGET spherecull_scene)
  sc_add_test(test_scene_modes SOURCES test_scene_modes.c LIBS spherecull_scene
              ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes)
  target_compile_definitions(test_scene_modes PRIVATE SC_SCENES_DIR="${PROJECT_SOURCE_DIR}/scenes")
endif()

# Concurrency as the headers state it: 4 threads trace one BVH while 2 build
# and free their own, every trace ISA. Label tsan: scripts/test.sh --tsan
# builds only this under ThreadSanitizer and runs it.
find_package(Threads REQUIRED)
sc_add_test(test_threads SOURCES test_threads.c LIBS Threads::Threads FTZ LABELS tsan)

# Packets return the single-ray hits bit for bit (every ISA, prefilter mode,
# leaf size; camera, edge-aimed, far, wide, shadow and mixed packets).
sc_add_test(test_packets SOURCES test_packets.c
            ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes FTZ)

# The compact sphere summary: each decoded sphere contains its triangle
# (MPFR), the same bits with FTZ|DAZ, unencodable leaves never reject.
sc_add_test(test_leaf_summary SOURCES test_leaf_summary.c FTZ)

# The scene handle: several meshes, instances (against each instance on
# its own and the MPFR oracle on its rounded object ray), refit.
if(TARGET spherecull_compare)
  sc_add_test(test_accel SOURCES test_accel.c LIBS spherecull_compare spherecull_scene FTZ)
endif()
