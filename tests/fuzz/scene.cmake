# Scene and prefilter fuzz targets; corpora in corpus/<name without fuzz_>.
if(TARGET spherecull_scene)
  sc_add_fuzzer(fuzz_scene_json fuzz_scene_json.c)
  target_link_libraries(fuzz_scene_json PRIVATE spherecull_scene)
  sc_add_fuzzer(fuzz_mesh_buffers fuzz_mesh_buffers.c)
  target_link_libraries(fuzz_mesh_buffers PRIVATE spherecull_scene)
endif()
sc_add_fuzzer(fuzz_ray_sphere fuzz_ray_sphere.c)
