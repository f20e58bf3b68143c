# SIMD kernels and the exact ray-triangle oracle.
sc_add_test(test_ref_ray SOURCES test_ref_ray.c)

# The kernel tests once per ISA level; a level this CPU lacks exits 77 and
# ctest reports it as skipped.
foreach(isa scalar sse4 avx2 avx512)
  sc_add_test(test_simd SOURCES test_simd.c ARGS ${isa} ENV SPHERECULL_ISA=${isa} FTZ)
  set_tests_properties(test_simd_${isa} test_simd_${isa}_ftz PROPERTIES SKIP_RETURN_CODE 77)
endforeach()
