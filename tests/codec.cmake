# Codec script tests: the JavaScript decoder (web/codec.js) against proto/vectors, in Node.
find_program(NODE_EXECUTABLE node)
if(NOT NODE_EXECUTABLE)
  message(FATAL_ERROR "node not found: install the Debian package 'nodejs' (or run .ci/deps)")
endif()
add_test(NAME codec_js COMMAND ${NODE_EXECUTABLE} --test ${CMAKE_CURRENT_SOURCE_DIR}/js/codec.test.mjs)
set_tests_properties(codec_js PROPERTIES LABELS no_asan TIMEOUT 300)
# A short `strandbench codec` run on synthetic frames: every row is printed, the Node half ran
# (meshopt row, JS decode figures for delta and keyframes) and the JS decoder was bit-exact.
add_test(NAME bench_codec_smoke
         COMMAND strandbench codec --synthetic --seconds 0.5 --strands 64 --verts 8 --js-frames 10 --json)
set_tests_properties(bench_codec_smoke PROPERTIES TIMEOUT 120
  PASS_REGULAR_EXPRESSION "\"codec\":\"strand\",\"error_bound_m\":2e-05,[^\n]*\"js_decode_ns_per_vertex\":[0-9.]+,\"js_key_decode_ns_per_vertex\":[0-9.]+,\"js_bit_exact\":true}\n[^\n]*\"codec\":\"quant\\+meshopt\\+deflate\",\"error_bound_m\":2e-05"
  FAIL_REGULAR_EXPRESSION "\"js_bit_exact\":false;Node benchmark failed")
# The same on one second of the real simulation (default scene, scripted head motion): the JS
# decoder is bit-exact with the C decoder on recorded solver frames, keyframes and deltas
# (release tree only: what it checks is the JS side, and the sim's auto backend probe loads
# lavapipe, whose allocations LeakSanitizer reports).
add_test(NAME bench_codec_sim_smoke COMMAND strandbench codec --seconds 1 --js-frames 10 --json)
set_tests_properties(bench_codec_sim_smoke PROPERTIES TIMEOUT 300 LABELS no_asan
  PASS_REGULAR_EXPRESSION "\"codec\":\"strand\",\"error_bound_m\":0.0005,[^\n]*\"js_bit_exact\":true}\n[^\n]*\n[^\n]*\n[^\n]*\n[^\n]*\"codec\":\"strand\",\"error_bound_m\":0.0001,[^\n]*\"js_bit_exact\":true}\n[^\n]*\n[^\n]*\n[^\n]*\n[^\n]*\"codec\":\"strand\",\"error_bound_m\":2e-05,[^\n]*\"js_bit_exact\":true}"
  FAIL_REGULAR_EXPRESSION "\"js_bit_exact\":false;Node benchmark failed")
