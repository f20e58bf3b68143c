# The shared helpers (src/common), the comparison harness (src/compare/
# tracer.h) and the command line's parsing, help and output-file contract.
sc_add_test(test_common SOURCES test_common.c LIBS spherecull_common)
sc_add_test(test_tracer SOURCES test_tracer.c LIBS spherecull_compare)
if(TARGET spherecull_cli)
  add_test(NAME cli_options
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/cli_options.sh $<TARGET_FILE:spherecull_cli> ${PROJECT_VERSION})
endif()
if(TARGET spherecull_cli)
  add_test(NAME cli_render
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/cli_render.sh $<TARGET_FILE:spherecull_cli>
                   ${PROJECT_SOURCE_DIR}/scenes/cornell.json)
endif()
# The MPI driver on loopback (tests/mpi.sh: render and compare; skipped,
# exit 77, without MPI). scripts/test.sh --sanitize builds without MPI.
if(TARGET spherecull_cli)
  if(TARGET spherecull_mpi)
    set(sc_mpi_built 1)
  else()
    set(sc_mpi_built 0)
  endif()
  add_test(NAME mpi
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/mpi.sh $<TARGET_FILE:spherecull_cli>
                   ${PROJECT_SOURCE_DIR}/scenes/cornell.json ${sc_mpi_built})
  set_tests_properties(mpi PROPERTIES SKIP_RETURN_CODE 77 LABELS mpi TIMEOUT 600)
endif()
