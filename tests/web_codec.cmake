# web codec: web/codec.js's tests once more with asm.js compilation off, so that the kernel
# (web/codec_kernel.js) runs as plain JavaScript, as in engines without asm.js.
find_program(STRANDCAST_NODE node)
if(NOT STRANDCAST_NODE)
  message(FATAL_ERROR "node not found: install the Debian package 'nodejs' (or run .ci/deps)")
endif()
add_test(NAME codec_js_plain
  COMMAND ${STRANDCAST_NODE} --no-validate-asm --test ${CMAKE_CURRENT_SOURCE_DIR}/js/codec.test.mjs)
set_tests_properties(codec_js_plain PROPERTIES LABELS no_asan TIMEOUT 300)
