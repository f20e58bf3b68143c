# Holes: vertex/edge rays through closed meshes, judged by the exact
# transversal-crossing classifier (src/compare/crossing.c). The real-mesh case
# reads ../shared/scenes when it exists and is skipped otherwise.
if(TARGET spherecull_compare AND TARGET spherecull_scene)
  sc_add_test(test_holes SOURCES test_holes.c LIBS spherecull_compare spherecull_scene
              ENV SC_TEST_SCENES=${PROJECT_SOURCE_DIR}/../shared/scenes FTZ)
  # What "watertight" does not promise: a ray clipping a convex edge within rounding.
  sc_add_test(test_watertight_limits SOURCES test_watertight_limits.c LIBS spherecull_compare)
endif()
