# Codec script tests: the JavaScript decoder (web/codec.js) against proto/vectors, in Node.
add_test(NAME codec_js COMMAND ${STRANDCAST_NODE} --test ${CMAKE_CURRENT_SOURCE_DIR}/js/codec.test.mjs)
set_tests_properties(codec_js PROPERTIES LABELS no_asan TIMEOUT 300)
# A short `strandbench codec` run on synthetic frames: every row is printed, the Node half ran
# (meshopt row, JS decode figures for delta and keyframes) and the JS decoder was bit-exact.
add_test(NAME bench_codec_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.codec === 'strand' && r.error_bound_m === 2e-5 && r.js_decode_ns_per_vertex > 0 && r.js_key_decode_ns_per_vertex > 0 && r.js_bit_exact === true"
           --row "r => r.codec === 'quant+meshopt+deflate' && r.error_bound_m === 2e-5"
           --none "r => r.js_bit_exact === false"
           -- $<TARGET_FILE:strandbench> codec --synthetic --seconds 0.5 --strands 64 --verts 8 --js-frames 10 --json)
set_tests_properties(bench_codec_smoke PROPERTIES TIMEOUT 120)
# The same on one second of the real simulation (default scene, scripted head motion): the JS
# decoder is bit-exact with the C decoder on recorded solver frames, keyframes and deltas
# (release tree only: what it checks is the JS side, and the sim's auto backend probe loads
# lavapipe, whose allocations LeakSanitizer reports).
add_test(NAME bench_codec_sim_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.codec === 'strand' && r.error_bound_m === 5e-4 && r.js_bit_exact === true"
           --row "r => r.codec === 'strand' && r.error_bound_m === 1e-4 && r.js_bit_exact === true"
           --row "r => r.codec === 'strand' && r.error_bound_m === 2e-5 && r.js_bit_exact === true"
           --none "r => r.js_bit_exact === false"
           -- $<TARGET_FILE:strandbench> codec --seconds 1 --js-frames 10 --json)
set_tests_properties(bench_codec_sim_smoke PROPERTIES TIMEOUT 300 LABELS no_asan)
# The decode core's portable path (server/codec/codec_core.c built with CODEC_CORE_PORTABLE: the
# path of targets with neither AVX2 nor WebAssembly SIMD) on the codec tests: the same bits.
file(GLOB STRANDCAST_CODEC_SOURCES CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/server/codec/*.c)
add_executable(test_codec_portable ${CMAKE_CURRENT_SOURCE_DIR}/test_codec.c ${STRANDCAST_CODEC_SOURCES})
target_compile_definitions(test_codec_portable PRIVATE CODEC_CORE_PORTABLE)
target_link_libraries(test_codec_portable PRIVATE strandcast PkgConfig::CMOCKA)
add_test(NAME test_codec_portable COMMAND test_codec_portable)
set_tests_properties(test_codec_portable PROPERTIES
  ENVIRONMENT "STRANDCAST_SOURCE_DIR=${PROJECT_SOURCE_DIR}" TIMEOUT 900)
# `strandbench codec --hairmesh`: the same hairstyle as strands and as its hair mesh, every bound
# met by both, the mesh frames a small fraction of the strand frames.
add_test(NAME bench_codec_hairmesh_smoke
         COMMAND ${STRANDCAST_NODE} ${STRANDCAST_EXPECT_ROWS}
           --row "r => r.codec === 'hairmesh' && r.error_bound_m === 1e-4 && r.max_error_m <= 1e-4 && r.ratio_to_strands < 0.5 && r.bytes_per_frame > 0"
           --row "r => r.codec === 'strand' && r.error_bound_m === 2e-5 && r.max_error_m <= 2e-5 && r.ratio_to_strands === 1"
           --none "r => r.max_error_m > r.error_bound_m"
           -- $<TARGET_FILE:strandbench> codec --hairmesh wavy --grid 4 --per-face 8 --verts 16 --seconds 0.25 --json)
set_tests_properties(bench_codec_hairmesh_smoke PROPERTIES TIMEOUT 60)
