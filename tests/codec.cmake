# Codec script tests: the JavaScript decoder (web/codec.js) against proto/vectors, in Node.
find_program(NODE_EXECUTABLE node)
if(NOT NODE_EXECUTABLE)
  message(FATAL_ERROR "node not found: install the Debian package 'nodejs' (or run .ci/deps)")
endif()
add_test(NAME codec_js COMMAND ${NODE_EXECUTABLE} --test ${CMAKE_CURRENT_SOURCE_DIR}/js/codec.test.mjs)
set_tests_properties(codec_js PROPERTIES LABELS no_asan TIMEOUT 300)
