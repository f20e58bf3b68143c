# Ray sets, the exact oracle and the Embree side by side.
sc_add_test(test_rays SOURCES test_rays.c LIBS spherecull_compare spherecull_scene)
sc_add_test(test_oracle SOURCES test_oracle.c LIBS spherecull_compare spherecull_scene FTZ)
if(TARGET spherecull_embree)
  sc_add_test(test_embree SOURCES test_embree.c LIBS spherecull_compare spherecull_embree spherecull_scene FTZ)
  # sc_rtcray.h's RTCRay offsets against embree3/rtcore_ray.h.
  sc_add_test(test_rtcray SOURCES test_rtcray.c LIBS spherecull_embree)
endif()
# compare's tracers, oracle and rows through a scene's instances.
sc_add_test(test_compare_instances SOURCES test_compare_instances.c LIBS spherecull_compare spherecull_scene FTZ)
