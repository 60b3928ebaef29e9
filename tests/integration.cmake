# Integration tests: the real strandcastd on a free loopback port, driven by WebSocket clients
# (tests/it/, with the lws client server/wsc/). One ctest test per scenario.
file(GLOB IT_SOURCES CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/it/*.c)
add_executable(it_net ${IT_SOURCES} ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c ${CMAKE_CURRENT_SOURCE_DIR}/support/rawws.c
                      ${CMAKE_CURRENT_SOURCE_DIR}/support/natsd.c ${CMAKE_CURRENT_SOURCE_DIR}/support/natscreds.c)
target_include_directories(it_net PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(it_net PRIVATE strandcast PkgConfig::CMOCKA PkgConfig::CRYPTO)
add_dependencies(it_net strandcastd strandcastc)
# one test per line of tests/it/scenarios.h (the same list it_main.c runs); the collider
# scenario reads the Ratboy groom and body from the shared assets (skipped without them)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/it/scenarios.h)
file(STRINGS ${CMAKE_CURRENT_SOURCE_DIR}/it/scenarios.h IT_SCENARIOS REGEX "^IT_SCENARIO\\(")
foreach(line ${IT_SCENARIOS})
  if(NOT line MATCHES "^IT_SCENARIO\\(([a-z0-9_]+), *[A-Za-z0-9_]+, *[A-Za-z0-9_]+, *([0-9]+), *\"([a-z_ ]+)\"\\)$")
    message(FATAL_ERROR "tests/it/scenarios.h: cannot read \"${line}\"")
  endif()
  set(name integration_${CMAKE_MATCH_1})
  string(REPLACE " " ";" labels "${CMAKE_MATCH_3}")
  add_test(NAME ${name} COMMAND it_net $<TARGET_FILE:strandcastd> test_${CMAKE_MATCH_1})
  set_tests_properties(${name} PROPERTIES TIMEOUT ${CMAKE_MATCH_2} LABELS "${labels}"
                       ENVIRONMENT "STRANDCAST_ASSETS=${PROJECT_SOURCE_DIR}/../shared/assets")
  if("serial" IN_LIST labels) # a timing bound: nothing else runs beside it
    set_tests_properties(${name} PROPERTIES RUN_SERIAL TRUE)
  endif()
endforeach()

# The JSON Schemas in proto/schema against sample messages and the real server (Node + ajv + ws).
add_test(NAME protocol_schema COMMAND ${STRANDCAST_NODE} --test ${CMAKE_CURRENT_SOURCE_DIR}/js/schema.test.mjs)
set_tests_properties(protocol_schema PROPERTIES LABELS "integration;no_asan" TIMEOUT 120
                     ENVIRONMENT "STRANDCASTD=$<TARGET_FILE:strandcastd>")

# strandbench fanout drives the real daemon with lean raw-socket receivers (tests/bench/fanout_rx.c)
# and the tests' lws client for control messages.
target_sources(strandbench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c
                                   ${CMAKE_CURRENT_SOURCE_DIR}/support/rawws.c
                                   ${CMAKE_CURRENT_SOURCE_DIR}/support/natsd.c)
target_include_directories(strandbench PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
add_dependencies(strandbench strandcastd)
# A short fan-out run: the receivers parse the stream (frames counted, a moving head so the frames
# are large and span many reads) and every client gets frames.
add_test(NAME bench_fanout_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'fanout' && r.clients === 3 && r.min_frames_per_client_per_s >= 1"
           -- $<TARGET_FILE:strandbench> fanout --clients 3 --seconds 2 --warmup 1 --animate shake --json)
set_tests_properties(bench_fanout_smoke PROPERTIES TIMEOUT 120 LABELS integration)
# The same in edge mode: a simulation node and two edge relays over nats-server, 16 clients spread
# over them; every client gets frames and the node publishes each stream frame once (at most the
# daemon's 60 frames/s, not once per client: 16 clients of a 30 Hz stream would be 480). The edges'
# CPU comes from /proc in 10 ms ticks: 16 clients for 3 s give each edge several (4 for 2 s gave
# none on CI's loaded run).
add_test(NAME bench_fanout_edges_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'fanout' && r.edges === 2 && r.clients === 16 && r.min_frames_per_client_per_s >= 1 && r.node_published_per_s > 0 && r.node_published_per_s < 65 && r.edge_us_per_client_frame > 0"
           -- $<TARGET_FILE:strandbench> fanout --edges 2 --clients 16 --seconds 3 --warmup 1 --strands 512 --verts 16 --animate shake --json)
set_tests_properties(bench_fanout_edges_smoke PROPERTIES TIMEOUT 120 LABELS "integration;nats")
# A short latency run: every change gets a reply with its step and a frame at that step; the
# figures are only checked for sanity (a loaded machine is slow), strandbench latency measures.
add_test(NAME bench_latency_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'latency' && r.changes === 20 && r.p50_ms > 0 && r.p50_ms <= r.p99_ms && r.p99_ms <= r.max_ms && r.max_ms < 10000 && r.reply_p50_ms > 0 && r.reply_p50_ms <= r.p50_ms && r.frames >= 20"
           -- $<TARGET_FILE:strandbench> latency --changes 20 --json)
set_tests_properties(bench_latency_smoke PROPERTIES TIMEOUT 120 LABELS integration)
# The hair-mesh benchmark runs its three sizes and reports every stage (figures: BENCHMARKS.md).
add_test(NAME bench_hairmesh_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'hairmesh' && r.vertices === 216 && r.threads === 1 && r.ms_per_frame > 0 && r.cg_ms > 0 && r.forces_ms > 0"
           --row "r => r.bench === 'hairmesh' && r.vertices === 360 && r.paper_vertices === 361"
           --row "r => r.bench === 'hairmesh' && r.vertices === 2304 && r.cpu_ms_per_frame > 0 && r.collisions_ms >= 0 && r.deform_min_ms >= 0"
           -- $<TARGET_FILE:strandbench> hairmesh --frames 5 --json)
set_tests_properties(bench_hairmesh_smoke PROPERTIES TIMEOUT 120 LABELS integration)
# A change that comes while the sim thread waits for the next step's time shows at once (the
# step runs ahead of the clock, app_sim.c): on a tiny groom in about a millisecond, where waiting
# for the next 60 Hz slot took a whole step (16.7 ms). A timing bound: nothing runs beside it.
add_test(NAME latency_change_shows_at_once
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'latency' && r.changes === 60 && r.p50_ms < 5"
           -- $<TARGET_FILE:strandbench> latency --changes 60 --strands 128 --verts 8 --json)
set_tests_properties(latency_change_shows_at_once PROPERTIES TIMEOUT 120 LABELS "integration;no_asan;serial" RUN_SERIAL TRUE)
# strandbench --help names every benchmark.
add_test(NAME strandbench_help COMMAND strandbench --help)
set_tests_properties(strandbench_help PROPERTIES TIMEOUT 30
                     PASS_REGULAR_EXPRESSION "\n  solver [^\n]+\n  codec [^\n]+\n  fanout [^\n]+")
# strandbench quality runs a parameter of another solver than the default under that solver
# (pbd_iterations under pbd, as the row's "solver" says) and refuses a hair-mesh solver's.
add_test(NAME strandbench_quality_solver_params
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.bench === 'quality' && r.param === 'pbd_iterations' && r.value === 1 && r.solver === 'pbd'"
           --row "r => r.bench === 'quality' && r.param === 'pbd_iterations' && r.value === 32 && r.solver === 'pbd'"
           -- $<TARGET_FILE:strandbench> quality --groom straight --param pbd_iterations --strands 64 --verts 8
              --seconds-motion 0.25 --seconds-rest 0.25 --threads 1 --json)
set_tests_properties(strandbench_quality_solver_params PROPERTIES TIMEOUT 120 LABELS "integration")
add_test(NAME strandbench_quality_refuses_hm_param
         COMMAND strandbench quality --groom straight --param hm_damping --strands 64 --verts 8)
set_tests_properties(strandbench_quality_refuses_hm_param PROPERTIES TIMEOUT 30
                     PASS_REGULAR_EXPRESSION "hm_damping is a hair-mesh solver parameter")
