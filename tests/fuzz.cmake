# fuzz: libFuzzer targets (tests/fuzz/fuzz_*.c) for the control-message parser, the frame
# decoder, every file loader and the --replay record reader, built with clang directly
# (whatever compiles the rest) with their own sanitizers; each runs for a few seconds as a test,
# from the seeds in tests/fuzz/<target>/. Longer runs: tests/fuzz/README.md.
find_program(STRANDCAST_CLANG clang)
if(NOT STRANDCAST_CLANG)
  message(FATAL_ERROR "clang not found: install the Debian package 'clang' (or run .ci/deps)")
endif()

set(FUZZ_DIR ${CMAKE_CURRENT_BINARY_DIR}/fuzz)
set(FUZZ_FLAGS -std=c11 -D_POSIX_C_SOURCE=200809L -Wall -Wextra -Werror
    -ffp-contract=off -fno-math-errno -fno-trapping-math -g -O1 -fno-omit-frame-pointer
    -fno-sanitize-recover=undefined -I${PROJECT_SOURCE_DIR}/server)
if(STRANDCAST_NATIVE)
  list(APPEND FUZZ_FLAGS -march=native) # the SIMD kernels the daemon runs here
endif()

# The server modules the targets reach, instrumented for coverage and the sanitizers, in one
# archive (each target pulls only the objects it needs).
file(GLOB FUZZ_LIB_SOURCES CONFIGURE_DEPENDS
     ${PROJECT_SOURCE_DIR}/server/core/*.c ${PROJECT_SOURCE_DIR}/server/groom/*.c
     ${PROJECT_SOURCE_DIR}/server/proto/*.c ${PROJECT_SOURCE_DIR}/server/codec/*.c)
list(APPEND FUZZ_LIB_SOURCES ${PROJECT_SOURCE_DIR}/server/sim/sim_params.c ${PROJECT_SOURCE_DIR}/server/app/app_anim.c
     ${PROJECT_SOURCE_DIR}/server/app/app_rec_write.c ${PROJECT_SOURCE_DIR}/server/app/app_rec_read.c)
file(MAKE_DIRECTORY ${FUZZ_DIR}/obj)
set(FUZZ_OBJECTS)
foreach(src ${FUZZ_LIB_SOURCES})
  file(RELATIVE_PATH rel ${PROJECT_SOURCE_DIR}/server ${src})
  string(REPLACE "/" "_" obj ${rel})
  set(obj ${FUZZ_DIR}/obj/${obj}.o)
  add_custom_command(OUTPUT ${obj}
    COMMAND ${STRANDCAST_CLANG} ${FUZZ_FLAGS} -fsanitize=fuzzer-no-link,address,undefined
            -MD -MF ${obj}.d -c ${src} -o ${obj}
    DEPENDS ${src} DEPFILE ${obj}.d
    COMMENT "fuzz: compiling ${rel}" VERBATIM)
  list(APPEND FUZZ_OBJECTS ${obj})
endforeach()
set(FUZZ_LIB ${FUZZ_DIR}/libstrandcast_fuzz.a)
add_custom_command(OUTPUT ${FUZZ_LIB}
  COMMAND ${CMAKE_COMMAND} -E rm -f ${FUZZ_LIB}
  COMMAND ${CMAKE_AR} rcs ${FUZZ_LIB} ${FUZZ_OBJECTS}
  DEPENDS ${FUZZ_OBJECTS} COMMENT "fuzz: archiving the instrumented modules" VERBATIM)
# One target owns the archive, so parallel builds of the fuzzers never make it twice at once.
add_custom_target(fuzz_lib ALL DEPENDS ${FUZZ_LIB})

# strandcast_fuzz(NAME SOURCE SEEDS [DEFINES...]): builds fuzz_NAME from tests/fuzz/SOURCE and
# adds the test fuzz_NAME (4 s from the seeds in tests/fuzz/SEEDS, with the dictionary
# tests/fuzz/NAME.dict when there is one; release tree only, as the target carries its own
# sanitizers).
function(strandcast_fuzz name source seeds)
  set(exe ${FUZZ_DIR}/fuzz_${name})
  set(defs)
  foreach(d ${ARGN})
    list(APPEND defs -D${d})
  endforeach()
  add_custom_command(OUTPUT ${exe}
    COMMAND ${STRANDCAST_CLANG} ${FUZZ_FLAGS} ${defs} -fsanitize=fuzzer,address,undefined
            -MD -MF ${exe}.d ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/${source} ${FUZZ_LIB}
            -lcjson -lz -lm -o ${exe}
    DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/${source} ${FUZZ_LIB} DEPFILE ${exe}.d
    COMMENT "fuzz: linking fuzz_${name}" VERBATIM)
  add_custom_target(fuzz_${name} ALL DEPENDS ${exe})
  add_dependencies(fuzz_${name} fuzz_lib)
  set(dict)
  if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/${name}.dict)
    set(dict ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/${name}.dict)
  endif()
  add_test(NAME fuzz_${name}
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/run.sh ${exe} ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/${seeds} 4 ${dict})
  set_tests_properties(fuzz_${name} PROPERTIES LABELS "fuzz;no_asan" TIMEOUT 30)
endfunction()

strandcast_fuzz(proto fuzz_proto.c proto)
strandcast_fuzz(codec fuzz_codec.c codec)
strandcast_fuzz(tfx fuzz_groom.c tfx FUZZ_LOADER=1)
strandcast_fuzz(hair fuzz_groom.c hair FUZZ_LOADER=2)
strandcast_fuzz(obj fuzz_groom.c obj FUZZ_LOADER=3)
strandcast_fuzz(tfxmesh fuzz_groom.c tfxmesh FUZZ_LOADER=4)
strandcast_fuzz(hairmesh fuzz_groom.c hairmesh FUZZ_LOADER=5)
strandcast_fuzz(record fuzz_record.c record)
