# The OSMesa raster reference, once per depth-buffer mode.
if(TARGET spherecull_raster)
  sc_add_test(test_raster SOURCES test_raster.c LIBS spherecull_raster ARGS float)
  sc_add_test(test_raster SOURCES test_raster.c LIBS spherecull_raster ARGS fixed24)

  # End to end: raster-check exits non-zero unless our tracer agrees with the
  # raster on >= 99.5% of pixels with no "elsewhere" disagreement.
  if(TARGET spherecull_cli)
    foreach(spec proc:sphere:20k proc:soup:5k proc:slivers:5k proc:terrain:20k)
      string(REPLACE ":" "_" tname "cli_raster_check_${spec}")
      add_test(NAME ${tname}
               COMMAND spherecull_cli raster-check ${spec} --width 320 --height 240)
    endforeach()
    add_test(NAME cli_raster_outputs
             COMMAND spherecull_cli raster proc:sphere:2k --width 64 --height 48
                     -o ${CMAKE_CURRENT_BINARY_DIR}/raster_smoke.png
                     --ids ${CMAKE_CURRENT_BINARY_DIR}/raster_smoke_ids.png
                     --depth ${CMAKE_CURRENT_BINARY_DIR}/raster_smoke_depth.png)
    # Bad input: exactly one line on stderr, nothing on stdout, and the
    # documented exit status (1 runtime error, 2 usage error).
    set(expect_one_line [=[out=$("$0" "$@" 2>&1 >/dev/null); rc=$?; echo "$out"; [ "$rc" -eq "$EXPECT" ] && [ "$(printf '%s\n' "$out" | wc -l)" -eq 1 ]]=])
    add_test(NAME cli_raster_missing_scene
             COMMAND sh -c "${expect_one_line}" $<TARGET_FILE:spherecull_cli> raster
                     ${CMAKE_CURRENT_BINARY_DIR}/no_such_scene.obj -o ${CMAKE_CURRENT_BINARY_DIR}/never.png)
    add_test(NAME cli_raster_bad_option
             COMMAND sh -c "${expect_one_line}" $<TARGET_FILE:spherecull_cli> raster-check
                     proc:sphere:1k --width 0)
    set_tests_properties(cli_raster_missing_scene PROPERTIES ENVIRONMENT EXPECT=1)
    set_tests_properties(cli_raster_bad_option PROPERTIES ENVIRONMENT EXPECT=2)
  endif()
endif()
