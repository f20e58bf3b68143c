# The exact-decision triangle test (SC_TRI_EXACT, src/trace/tri_exact.c)
# against MPFR and the exact oracle. The shared-mesh case reads
# ../shared/scenes when it exists and is skipped otherwise.
if(TARGET spherecull_compare AND TARGET spherecull_scene)
  sc_add_test(test_exact_tri SOURCES test_exact_tri.c LIBS spherecull_compare spherecull_scene
              ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes FTZ)
endif()
