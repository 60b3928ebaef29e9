# Integration tests: the real strandcastd on a free loopback port, driven by WebSocket clients
# (tests/it_net.c with the lws client server/wsc/). One ctest test per scenario.
add_executable(it_net ${CMAKE_CURRENT_SOURCE_DIR}/it_net.c
                      ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c ${CMAKE_CURRENT_SOURCE_DIR}/support/rawws.c)
target_include_directories(it_net PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(it_net PRIVATE strandcast PkgConfig::CMOCKA)
add_dependencies(it_net strandcastd strandcastc)
foreach(t hello_and_frames params_broadcast_and_physics motion_moves_roots bad_inputs_keep_stream
          subprotocol_refused http_static_and_metrics pause_step_subscribe_groom slow_client_skips rate_streams
          stream_slots cli_client stream_failure_is_reported
          sigterm_closes_clients sigint_closes_clients listen_ipv6 default_address
          reader_that_never_reads_is_closed flags
          ping_drops_silent_client)
  add_test(NAME integration_${t} COMMAND it_net $<TARGET_FILE:strandcastd> test_${t})
  set_tests_properties(integration_${t} PROPERTIES TIMEOUT 120 LABELS integration)
endforeach()
# the Ratboy groom and body from the shared assets (skipped without them): two SDF builds of the
# body, seconds each (minutes under the sanitizers)
add_test(NAME integration_collider_mesh COMMAND it_net $<TARGET_FILE:strandcastd> test_collider_mesh)
set_tests_properties(integration_collider_mesh PROPERTIES TIMEOUT 900 LABELS integration
                     ENVIRONMENT "STRANDCAST_ASSETS=${PROJECT_SOURCE_DIR}/../shared/assets")

# The JSON Schemas in proto/schema against sample messages and the real server (Node + ajv + ws).
find_program(NODE_EXECUTABLE node)
if(NOT NODE_EXECUTABLE)
  message(FATAL_ERROR "node not found: install the Debian package 'nodejs' (or run .ci/deps)")
endif()
add_test(NAME protocol_schema COMMAND ${NODE_EXECUTABLE} --test ${CMAKE_CURRENT_SOURCE_DIR}/js/schema.test.mjs)
set_tests_properties(protocol_schema PROPERTIES LABELS "integration;no_asan" TIMEOUT 120
                     ENVIRONMENT "STRANDCASTD=$<TARGET_FILE:strandcastd>")

# strandbench fanout drives the real daemon with lean raw-socket receivers (tests/bench/fanout_rx.c)
# and the tests' lws client for control messages.
target_sources(strandbench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c
                                   ${CMAKE_CURRENT_SOURCE_DIR}/support/rawws.c)
target_include_directories(strandbench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
add_dependencies(strandbench strandcastd)
# A short fan-out run: the receivers parse the stream (frames counted, a moving head so the frames
# are large and span many reads) and every client gets frames.
add_test(NAME bench_fanout_smoke
         COMMAND strandbench fanout --clients 3 --seconds 2 --warmup 1 --animate shake --json)
set_tests_properties(bench_fanout_smoke PROPERTIES TIMEOUT 120 LABELS integration
                     PASS_REGULAR_EXPRESSION "\"clients\":3,[^\n]*\"min_frames_per_client_per_s\":[1-9]")
# strandbench --help names every benchmark.
add_test(NAME strandbench_help COMMAND strandbench --help)
set_tests_properties(strandbench_help PROPERTIES TIMEOUT 30
                     PASS_REGULAR_EXPRESSION "\n  solver [^\n]+\n  codec [^\n]+\n  fanout [^\n]+")
