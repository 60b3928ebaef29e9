# python: the Python client's own tests (tests/python/test_*.py, pytest): its decoder (the shared
# library libstrandcast_codec.so through ctypes) on proto/vectors, its client against a fresh
# strandcastd, and the README's Python example as written. Debian's interpreter and packages
# (python3-numpy, python3-websockets, python3-pytest; .ci/deps installs them). In the sanitizer
# tree the library is built with ASan, so Python runs with the ASan runtime preloaded (no leak
# check: the interpreter does not free everything at exit; test_codec_abi checks the C side's).
find_program(STRANDCAST_PYTHON python3 HINTS /usr/bin)
if(NOT STRANDCAST_PYTHON)
  message(FATAL_ERROR "python3 not found: install the Debian package 'python3' (or run .ci/deps)")
endif()
execute_process(COMMAND ${STRANDCAST_PYTHON} -c "import numpy, websockets, pytest"
                RESULT_VARIABLE STRANDCAST_PYTHON_MODULES OUTPUT_QUIET ERROR_QUIET)
if(NOT STRANDCAST_PYTHON_MODULES EQUAL 0)
  message(FATAL_ERROR "${STRANDCAST_PYTHON} cannot import numpy, websockets and pytest: install the Debian "
                      "packages 'python3-numpy python3-websockets python3-pytest' (or run .ci/deps)")
endif()

set(STRANDCAST_PYTHON_ENV
  "PYTHONPATH=${CMAKE_CURRENT_SOURCE_DIR}/python"
  "PYTHONDONTWRITEBYTECODE=1"
  "STRANDCAST_CODEC_LIB=$<TARGET_FILE:strandcast_codec>"
  "STRANDCASTD=$<TARGET_FILE:strandcastd>")
if(STRANDCAST_SANITIZE)
  execute_process(COMMAND ${CMAKE_C_COMPILER} -print-file-name=libasan.so
                  OUTPUT_VARIABLE STRANDCAST_LIBASAN OUTPUT_STRIP_TRAILING_WHITESPACE)
  list(APPEND STRANDCAST_PYTHON_ENV "LD_PRELOAD=${STRANDCAST_LIBASAN}"
       "ASAN_OPTIONS=detect_leaks=0:abort_on_error=1")
endif()

file(GLOB STRANDCAST_PYTHON_TESTS CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/python/test_*.py)
foreach(f ${STRANDCAST_PYTHON_TESTS})
  get_filename_component(name ${f} NAME_WE)
  add_test(NAME python_${name}
           COMMAND ${STRANDCAST_PYTHON} -m pytest -q -p no:cacheprovider --rootdir ${CMAKE_CURRENT_SOURCE_DIR}/python ${f}
           WORKING_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/python)
  set_tests_properties(python_${name} PROPERTIES ENVIRONMENT "${STRANDCAST_PYTHON_ENV}" TIMEOUT 300
                       LABELS python)
endforeach()
