# Scenes and bad input: loaders, procedural scenes, PNG.
if(TARGET spherecull_scene)
  foreach(t test_scene test_scene_bad)
    sc_add_test(${t} SOURCES ${t}.c LIBS spherecull_scene)
    target_compile_definitions(${t} PRIVATE SC_TEST_DATA="${CMAKE_CURRENT_SOURCE_DIR}/data")
  endforeach()
endif()
if(TARGET spherecull_render)
  sc_add_test(test_png SOURCES test_png.c LIBS spherecull_render)
endif()
if(TARGET spherecull_render AND TARGET spherecull_scene)
  sc_add_test(test_render SOURCES test_render.c LIBS spherecull_render spherecull_scene)
endif()
if(TARGET spherecull_render AND TARGET spherecull_scene)
  # The path tracer; with Embree built also its agreement with our tracer.
  sc_add_test(test_path SOURCES test_path.c LIBS spherecull_render spherecull_scene spherecull_compare FTZ)
endif()
if(TARGET spherecull_render AND TARGET spherecull_scene)
  # Scene files with instances: the loader's two forms, bad fields, and the
  # render through the instances against the flattened mesh's.
  sc_add_test(test_scene_instances SOURCES test_scene_instances.c LIBS spherecull_render spherecull_scene)
endif()
