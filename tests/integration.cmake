# Integration tests: the real strandcastd on a free loopback port, driven by WebSocket clients
# (tests/it_net.c with the lws client in tests/support/). One ctest test per scenario.
add_executable(it_net ${CMAKE_CURRENT_SOURCE_DIR}/it_net.c ${CMAKE_CURRENT_SOURCE_DIR}/support/wsc.c
                      ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c ${CMAKE_CURRENT_SOURCE_DIR}/support/rawws.c)
target_include_directories(it_net PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(it_net PRIVATE strandcast PkgConfig::CMOCKA)
add_dependencies(it_net strandcastd)
foreach(t hello_and_frames params_broadcast_and_physics motion_moves_roots bad_inputs_keep_stream
          subprotocol_refused http_static_and_metrics pause_step_subscribe_groom slow_client_skips)
  add_test(NAME integration_${t} COMMAND it_net $<TARGET_FILE:strandcastd> test_${t})
  set_tests_properties(integration_${t} PROPERTIES TIMEOUT 120 LABELS integration)
endforeach()
