# Bad input and faults. test_scene_bad is registered with the
# scene tests (scene.cmake); here: the CLI contract and the fuzz corpora.

# Every CLI command on missing/directory/damaged inputs, unwritable outputs
# and absurd numbers: one line on stderr, non-zero exit, nothing left behind.
if(TARGET spherecull_cli)
  add_test(NAME cli_bad_input
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/cli_bad_input.sh $<TARGET_FILE:spherecull_cli>
                   ${CMAKE_CURRENT_SOURCE_DIR}/data)
endif()

# The fuzz corpora replayed (the targets abort on a broken invariant), so
# every seed and every crash once found stays a regression test.
set(sc_fuzz_corpus ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/corpus)
if(TARGET spherecull_scene)
  foreach(t scene_json mesh_buffers)
    sc_add_test(test_fuzz_replay_${t} SOURCES fuzz_replay.c fuzz/fuzz_${t}.c LIBS spherecull_scene
                ARGS ${sc_fuzz_corpus}/${t} TEST_NAME test_fuzz_replay_${t})
  endforeach()
endif()
sc_add_test(test_fuzz_replay_ray_sphere SOURCES fuzz_replay.c fuzz/fuzz_ray_sphere.c
            ARGS ${sc_fuzz_corpus}/ray_sphere TEST_NAME test_fuzz_replay_ray_sphere)

# Crashes found whose fix lies outside the fuzzed files' owners' reach so
# far (see docs/bad-input.md, "Open"): each must still fail. When one
# passes, the bug is fixed: move its input into fuzz/corpus/<name>/.
file(GLOB sc_pending_dirs LIST_DIRECTORIES true ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/pending/*)
foreach(dir ${sc_pending_dirs})
  get_filename_component(t ${dir} NAME)
  file(GLOB inputs ${dir}/*)
  foreach(input ${inputs})
    get_filename_component(n ${input} NAME)
    if(TARGET test_fuzz_replay_${t})
      add_test(NAME test_fuzz_pending_${t}_${n}
               COMMAND sh -c "tmp=$(mktemp -d) && cp \"$1\" \"$tmp/\" && ! \"$0\" \"$tmp\" >/dev/null 2>&1; rc=$?; rm -rf \"$tmp\"; exit $rc"
                       $<TARGET_FILE:test_fuzz_replay_${t}> ${input})
    endif()
  endforeach()
endforeach()
