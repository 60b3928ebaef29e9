# shaders: cmake -P script writing a SPIR-V binary (IN) as a C uint32_t array named
# sim_vk_spv_<NAME> plus its byte size into OUT (SPIR-V is a stream of little-endian words).
file(READ ${IN} hex HEX)
string(LENGTH "${hex}" nhex)
math(EXPR rem "${nhex} % 8")
if(nhex EQUAL 0 OR NOT rem EQUAL 0)
  message(FATAL_ERROR "${IN}: not a SPIR-V module (${nhex} hex digits)")
endif()
math(EXPR nbytes "${nhex} / 2")
string(REGEX REPLACE "(..)(..)(..)(..)" "0x\\4\\3\\2\\1u,\n" words "${hex}")
file(WRITE ${OUT} "/* generated from ${NAME}.comp by shaders/embed_spirv.cmake */
#include <stddef.h>
#include <stdint.h>
#include \"sim_vk_spv.h\"
const uint32_t sim_vk_spv_${NAME}[] = {
${words}};
const size_t sim_vk_spv_${NAME}_size = ${nbytes};
")
