# strandcastd --record / --replay (proto/RECORD.md): a 600-step session with motion, parameter
# changes, a preset, pause and single steps and a reset is recorded through the real daemon (with
# a position digest per step), then replayed with --no-net: the daemon checks every step's
# positions bit for bit against the recording's digests and stops with an error at the first
# that differs. Then: a replay streams like a live session and refuses changes (bad_state), ends
# paused and live; a file that is no recording, of another version, truncated or corrupt is
# refused at start-up, naming the byte, record and field; a disk that fails (/dev/full) is
# reported in /metrics while the simulation goes on.
set(replay_dir ${CMAKE_CURRENT_SOURCE_DIR}/replay)
set(replay_file ${CMAKE_CURRENT_BINARY_DIR}/replay_session.screc)
set(replay_sh "/bin/sh")

# with_daemon's arguments, then the command line after -- (as strandcast_scenario_test, which
# scenarios.cmake defines after this file is read)
function(strandcast_replay_daemon_test name)
  add_test(NAME ${name} COMMAND $<TARGET_FILE:with_daemon> $<TARGET_FILE:strandcastd> ${ARGN})
  set_tests_properties(${name} PROPERTIES TIMEOUT 180 LABELS integration)
endfunction()

strandcast_replay_daemon_test(replay_record --expect "steps held"
  --daemon --record --daemon ${replay_file} --daemon --record-digests
  -- $<TARGET_FILE:strandcastc> run --port {port} ${replay_dir}/session.json)
set_tests_properties(replay_record PROPERTIES FIXTURES_SETUP replay_file)

function(strandcast_replay_test name)
  strandcast_replay_daemon_test(${name} ${ARGN})
  set_tests_properties(${name} PROPERTIES FIXTURES_REQUIRED replay_file)
endfunction()

# session.json runs at least 650 steps (330 before its reset, 200 after it, then 120 frames of the new groom)
strandcast_replay_test(replay_bit_exact --expect "every step's positions ("
  -- $<TARGET_FILE:strandcastd> --replay ${replay_file} --no-net)
strandcast_replay_test(replay_refuses_changes --expect "steps held" --daemon --replay --daemon ${replay_file}
  -- $<TARGET_FILE:strandcastc> run --port {port} ${replay_dir}/refused.json)
strandcast_replay_test(replay_ends_live --expect "steps held" --daemon --replay --daemon ${replay_file}
  -- $<TARGET_FILE:strandcastc> run --port {port} ${replay_dir}/ends_live.json)
strandcast_replay_test(replay_not_a_recording --exit 1 --expect "byte 0: field magic: not a strandcast recording"
  -- $<TARGET_FILE:strandcastd> --replay ${replay_dir}/session.json --no-net)
strandcast_replay_test(replay_bad_version --exit 1
  --expect "byte 8: field version: format version 2" --expect "this strandcastd reads version 1"
  -- ${replay_sh} -c "cp \"$1\" \"$2\" && printf '\\002' | dd of=\"$2\" bs=1 seek=8 conv=notrunc 2>/dev/null && exec \"$3\" --replay \"$2\" --no-net"
     sh ${replay_file} ${CMAKE_CURRENT_BINARY_DIR}/replay_v2.screc $<TARGET_FILE:strandcastd>)
strandcast_replay_test(replay_truncated --exit 1 --expect ": field length: truncated: the record takes"
  -- ${replay_sh} -c "head -c 1010 \"$1\" > \"$2\" && exec \"$3\" --replay \"$2\" --no-net"
     sh ${replay_file} ${CMAKE_CURRENT_BINARY_DIR}/replay_cut.screc $<TARGET_FILE:strandcastd>)
strandcast_replay_test(replay_corrupt --exit 1 --expect "record 0 at byte 12: field crc32: the bytes do not match"
  -- ${replay_sh} -c "cp \"$1\" \"$2\" && printf 'X' | dd of=\"$2\" bs=1 seek=40 conv=notrunc 2>/dev/null && exec \"$3\" --replay \"$2\" --no-net"
     sh ${replay_file} ${CMAKE_CURRENT_BINARY_DIR}/replay_bad.screc $<TARGET_FILE:strandcastd>)
strandcast_replay_daemon_test(replay_record_disk_full --expect "steps held" --expect "strandcast_record_errors_total "
  --daemon --record --daemon /dev/full
  -- ${replay_sh} -c "\"$1\" run --port \"$2\" \"$3\" && sleep 0.5 && curl -s http://127.0.0.1:$2/metrics | grep -E '^strandcast_record_errors_total [1-9]'"
     sh $<TARGET_FILE:strandcastc> {port} ${replay_dir}/full.json)

# Steps abandoned for a change (sim_set_cancel) leave no trace: a session whose parameter changes
# abandon steps in progress (abandon.json expects strandcast_steps_abandoned_total >= 1) on a
# groom of 3,072 x 32 with SPH and two threads, recorded and replayed bit for bit. Timing decides
# which steps are abandoned: run alone, and not under the sanitizers, whose steps fall behind real
# time (no step is abandoned then); test_sim_cancel covers the undoing there.
set(abandon_file ${CMAKE_CURRENT_BINARY_DIR}/replay_abandon.screc)
strandcast_replay_daemon_test(replay_record_abandon --expect "steps held"
  --daemon --strands --daemon 3072 --daemon --verts --daemon 32 --daemon --threads --daemon 2
  --daemon --record --daemon ${abandon_file} --daemon --record-digests
  -- $<TARGET_FILE:strandcastc> run --port {port} ${replay_dir}/abandon.json)
set_tests_properties(replay_record_abandon PROPERTIES FIXTURES_SETUP replay_abandon_file
                     LABELS "integration;no_asan;serial" RUN_SERIAL TRUE)
strandcast_replay_daemon_test(replay_abandon_bit_exact --expect "every step's positions ("
  -- $<TARGET_FILE:strandcastd> --replay ${abandon_file} --no-net)
set_tests_properties(replay_abandon_bit_exact PROPERTIES FIXTURES_REQUIRED replay_abandon_file
                     LABELS "integration;no_asan")

# strandcastc --compare on small SCFR files (tests/replay/compare_*.scfr): b differs from a by
# (3, 4, 0) mm at frame 1, strand 1, vertex 2; shape has another strand count; cut is truncated.
set(cmp $<TARGET_FILE:strandcastc> --compare)
strandcast_replay_daemon_test(compare_reports_largest
  --expect "frame 0: max difference 0 m at strand 0, vertex 0"
  --expect "frame 1: max difference 0.005 m at strand 1, vertex 2"
  --expect "2 frames of 2 strands x 3 vertices: largest difference 0.005 m at frame 1, strand 1, vertex 2"
  -- ${cmp} ${replay_dir}/compare_a.scfr ${replay_dir}/compare_b.scfr)
strandcast_replay_daemon_test(compare_json
  --expect "{\"frame\":1,\"max_diff\":0.00500000082,\"strand\":1,\"vertex\":2}"
  --expect "{\"summary\":true,\"frames\":2,\"max_diff\":0.00500000082,\"frame\":1,\"strand\":1,\"vertex\":2,\"identical\":false}"
  -- ${cmp} ${replay_dir}/compare_a.scfr ${replay_dir}/compare_b.scfr --json)
strandcast_replay_daemon_test(compare_identical --expect "largest difference 0 m at frame 0, strand 0, vertex 0 (identical)"
  -- ${cmp} ${replay_dir}/compare_b.scfr ${replay_dir}/compare_b.scfr)
strandcast_replay_daemon_test(compare_other_shape --exit 1
  --expect "cannot compare: ${replay_dir}/compare_a.scfr has 2 strands x 3 vertices, 2 frames"
  --expect "compare_shape.scfr has 3 x 3, 2 frames"
  -- ${cmp} ${replay_dir}/compare_a.scfr ${replay_dir}/compare_shape.scfr)
strandcast_replay_daemon_test(compare_truncated --exit 1
  --expect "compare_cut.scfr: 155 bytes, its header (2 strands x 3 vertices, 2 frames) says 160 (truncated or corrupt)"
  -- ${cmp} ${replay_dir}/compare_a.scfr ${replay_dir}/compare_cut.scfr)
strandcast_replay_daemon_test(compare_bad_use --exit 2 --expect "--compare: takes two files"
  -- ${cmp} ${replay_dir}/compare_a.scfr)

# flags: --record and --replay exclude each other, --record-digests needs --record; strandbench
# record runs (a smoke test: its figures are for BENCHMARKS.md, not a timed test)
strandcast_replay_daemon_test(replay_flags_exclusive --exit 2 --expect "--record" --expect "not with --replay"
  -- $<TARGET_FILE:strandcastd> --record ${CMAKE_CURRENT_BINARY_DIR}/replay_x.screc --replay ${replay_file})
strandcast_replay_daemon_test(replay_flags_digests_alone --exit 2 --expect "needs --record FILE"
  -- $<TARGET_FILE:strandcastd> --record-digests)
strandcast_replay_daemon_test(bench_record_smoke --expect "scene 64 x 8, 4 substeps, C backend, 1 rounds of 5 steps"
  --expect "% of the step (budget 2%)"
  -- $<TARGET_FILE:strandbench> record --steps 5 --rounds 1 --strands 64 --verts 8)
