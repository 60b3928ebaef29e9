# web wasm: the WebAssembly decode kernel committed as web/codec_kernel_wasm.js must be what
# web/wasm/build.sh makes from server/codec/codec_core.c (clang + wasm-ld), so that the source and
# the binary the page runs cannot drift apart.
find_program(STRANDCAST_CLANG clang)
find_program(STRANDCAST_WASM_LD wasm-ld)
if(NOT STRANDCAST_CLANG OR NOT STRANDCAST_WASM_LD)
  message(FATAL_ERROR "clang or wasm-ld not found: install the Debian packages 'clang lld' (or run .ci/deps)")
endif()
add_test(NAME web_wasm_kernel_built
  COMMAND sh -c "'${PROJECT_SOURCE_DIR}/web/wasm/build.sh' '${CMAKE_CURRENT_BINARY_DIR}/codec_kernel_wasm.js' && \
cmp '${CMAKE_CURRENT_BINARY_DIR}/codec_kernel_wasm.js' '${PROJECT_SOURCE_DIR}/web/codec_kernel_wasm.js' || \
{ echo 'web/codec_kernel_wasm.js is stale: run web/wasm/build.sh and commit it'; exit 1; }")
set_tests_properties(web_wasm_kernel_built PROPERTIES LABELS "web;no_asan" TIMEOUT 120)
