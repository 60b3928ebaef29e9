# Scenario scripts (tests/scenarios/*.json, run by `strandcastc run`) against a fresh strandcastd
# on a free port (tests/support/with_daemon.c starts it with --min-step-rate 0 and the test flags),
# plus `strandcastc run` failing (exit 1, the step named) and refusing bad scripts (exit 2, the
# step and field named), and `strandcastc check`.
add_executable(with_daemon ${CMAKE_CURRENT_SOURCE_DIR}/support/with_daemon.c ${CMAKE_CURRENT_SOURCE_DIR}/support/daemon.c)
target_include_directories(with_daemon PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
add_dependencies(with_daemon strandcastd strandcastc)

# with_daemon's arguments, then the strandcastc command line after --
function(strandcast_scenario_test name)
  add_test(NAME ${name} COMMAND with_daemon $<TARGET_FILE:strandcastd> ${ARGN})
  set_tests_properties(${name} PROPERTIES TIMEOUT 180 LABELS integration)
endfunction()

file(GLOB STRANDCAST_SCENARIOS CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/scenarios/*.json)
foreach(script ${STRANDCAST_SCENARIOS})
  get_filename_component(name ${script} NAME_WE)
  strandcast_scenario_test(scenario_${name} --expect "steps held" -- $<TARGET_FILE:strandcastc> run --port {port} ${script})
endforeach()

set(fail ${CMAKE_CURRENT_SOURCE_DIR}/scenarios/fail)
strandcast_scenario_test(scenario_fails_expect --exit 1
  --expect "FAIL step 2 expect" --expect "step 2 (expect) failed: params.gravity = 2 (want 3)"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/expect_fails.json)
strandcast_scenario_test(scenario_fails_metrics --exit 1
  --expect "step 1 (expect) failed: metrics.strandcast_steps_total = "
  --expect "(want in [1e+12, inf])"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/metrics_fails.json)
strandcast_scenario_test(scenario_fails_metrics_absent --exit 1
  --expect "step 0 (expect) failed: metrics.strandcast_no_such_sample = (absent)"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/metrics_absent.json)
strandcast_scenario_test(scenario_fails_reply --exit 1
  --expect "step 1 (reply) failed: reply to id \"x\": error out_of_range, field \"values.gravity\" (want error bad_field, field \"values.gravity\")"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/reply_fails.json)
strandcast_scenario_test(scenario_fails_check --exit 1
  --expect "\"step\":1,\"kind\":\"check\",\"ok\":false" --expect "frame rate: " --expect "\"failed_step\":1"
  -- $<TARGET_FILE:strandcastc> run --json --port {port} ${fail}/check_fails.json)
strandcast_scenario_test(scenario_fails_no_frames --exit 1 --expect "step 3 (check) failed: no frame in 0.5 s"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/check_no_frames.json)
strandcast_scenario_test(scenario_bad_kind --exit 2 --expect "step 1: unknown step kind (fields: teleport)"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/bad_kind.json)
strandcast_scenario_test(scenario_bad_type --exit 2
  --expect "step 2 (reply): field \"timeout_ms\": must be a number"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/bad_type.json)
strandcast_scenario_test(scenario_bad_number --exit 2
  --expect "step 0 (sleep_ms): field \"sleep_ms\": must be a finite number"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/bad_number.json)
strandcast_scenario_test(scenario_bad_json --exit 2 --expect "not valid JSON (line 3"
  -- $<TARGET_FILE:strandcastc> run --port {port} ${fail}/bad_json.json)
strandcast_scenario_test(scenario_no_script --exit 2 --expect "SCRIPT.json"
  -- $<TARGET_FILE:strandcastc> run --port {port})
strandcast_scenario_test(check_holds --expect "\"kind\":\"check\",\"ok\":true" --expect "\"root\":{\"frames_failed\":0"
  -- $<TARGET_FILE:strandcastc> check --port {port} --frames 60 --max-gap-ms 5000 --json)
strandcast_scenario_test(check_fails_rate --exit 1 --expect "frame rate: "
  -- $<TARGET_FILE:strandcastc> check --port {port} --frames 10 --min-fps 100000)
strandcast_scenario_test(check_bad_flag --exit 2 --expect "--max-depth x"
  -- $<TARGET_FILE:strandcastc> check --port {port} --max-depth x)
# --room NAME: strandcastc (run, check and the plain client) joins a named room at /rooms/NAME;
# another room is refused with the server's reason, a name that is not a room name before connecting.
set(room_script ${CMAKE_CURRENT_SOURCE_DIR}/scenarios/rooms/lab.json)
strandcast_scenario_test(scenario_room --daemon --room --daemon lab --expect "all 5 steps held"
  -- $<TARGET_FILE:strandcastc> run --room lab --port {port} ${room_script})
strandcast_scenario_test(strandcastc_check_room --daemon --room --daemon lab --expect "all 1 steps held"
  -- $<TARGET_FILE:strandcastc> check --room lab --port {port} --frames 20 --max-gap-ms 5000)
strandcast_scenario_test(strandcastc_room_frames --daemon --room --daemon lab --expect "2 frames"
  -- $<TARGET_FILE:strandcastc> --room lab --port {port} --frames 2)
strandcast_scenario_test(scenario_room_refused --daemon --room --daemon lab --exit 1
  --expect "no usable hello from the server: " --expect "\"code\":\"unknown_room\""
  -- $<TARGET_FILE:strandcastc> run --room other --port {port} ${room_script})
strandcast_scenario_test(strandcastc_room_bad_name --exit 2 --expect "--room bad/name: is not a room name"
  -- $<TARGET_FILE:strandcastc> --room bad/name --port {port})
