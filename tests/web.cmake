# web: Node tests of the viewer's JavaScript modules (web_js_client runs strandcastd): every
# tests/js/NAME.test.mjs but the codec's and the protocol schema's (codec.cmake and
# integration.cmake register those).
file(GLOB STRANDCAST_WEB_JS_FILES CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/js/*.test.mjs)
foreach(f ${STRANDCAST_WEB_JS_FILES})
  get_filename_component(file ${f} NAME)
  string(REGEX REPLACE "\\.test\\.mjs$" "" name ${file})
  if(name STREQUAL "codec" OR name STREQUAL "schema")
    continue()
  endif()
  add_test(NAME web_js_${name} COMMAND ${STRANDCAST_NODE} --test ${f})
  # the client module's test talks to a real daemon (this build's)
  if(name STREQUAL "client")
    set_tests_properties(web_js_${name} PROPERTIES ENVIRONMENT "STRANDCASTD=$<TARGET_FILE:strandcastd>")
  endif()
  # pure JavaScript: nothing for the sanitizers to check, so it runs in the release tree only
  set_tests_properties(web_js_${name} PROPERTIES LABELS "web;no_asan" TIMEOUT 120)
endforeach()

# The browser end-to-end test: the release daemon serving web/, headless Chromium (SwiftShader
# WebGL2) through playwright-core (tests/node_modules, installed by .ci/deps), a second
# WebSocket client (npm ws). Prints the viewer benchmark lines ({"bench":"web_e2e",...}); the
# screenshot and logs go to <build>/e2e/. SwiftShader is slow, hence the long timeout.
add_test(NAME web_e2e
  COMMAND ${STRANDCAST_NODE} ${CMAKE_CURRENT_SOURCE_DIR}/e2e/e2e.mjs
          --daemon $<TARGET_FILE:strandcastd> --web ${PROJECT_SOURCE_DIR}/web --out ${CMAKE_BINARY_DIR}/e2e)
set_tests_properties(web_e2e PROPERTIES LABELS "web;e2e;no_asan" TIMEOUT 2400 RUN_SERIAL TRUE)
# The hair grown from a streamed hair mesh in the browser (tests/e2e/hairmesh.mjs): strandcastd
# on the hair-mesh solver, the viewer subscribed to the mesh, the canvas checked for shaded hair,
# the wireframe overlay, and the fall-back to strands when the solver changes. Screenshots in
# <build>/e2e/hairmesh-*.png.
add_test(NAME web_e2e_hairmesh
  COMMAND ${STRANDCAST_NODE} ${CMAKE_CURRENT_SOURCE_DIR}/e2e/hairmesh.mjs
          --daemon $<TARGET_FILE:strandcastd> --web ${PROJECT_SOURCE_DIR}/web --out ${CMAKE_BINARY_DIR}/e2e)
set_tests_properties(web_e2e_hairmesh PROPERTIES LABELS "web;e2e;no_asan" TIMEOUT 900 RUN_SERIAL TRUE)
# A room's page through an edge relay (tests/e2e/edge.mjs): nats-server, a simulation node, an edge,
# the viewer at the edge's /rooms/NAME drawing hair (its groom data binary came through the edge)
# and a parameter change acknowledged. Screenshot in <build>/e2e/edge-room.png.
add_test(NAME web_e2e_edge
  COMMAND ${STRANDCAST_NODE} ${CMAKE_CURRENT_SOURCE_DIR}/e2e/edge.mjs
          --daemon $<TARGET_FILE:strandcastd> --web ${PROJECT_SOURCE_DIR}/web --out ${CMAKE_BINARY_DIR}/e2e)
set_tests_properties(web_e2e_edge PROPERTIES LABELS "web;e2e;no_asan;nats" TIMEOUT 900 RUN_SERIAL TRUE)
