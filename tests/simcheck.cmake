# The solver tests' shared support (tests/support/sim_check.c: head motion, groom fixture,
# geometric checks; tests/support/quality.c: the hair quality metrics; tests/support/vkpin.c:
# the LeakSanitizer pin of the Vulkan driver) as a static library linked into test_sim,
# test_sim_rest, test_sim_pbd, test_sim_collide, test_sim_volume, test_sim_cancel, test_sim_vk,
# test_sim_vk_pbd, test_sim_vk_sizes, test_codec_sim, test_quality, test_groom (the fitted
# head's simulation check), test_sim_hm (the violent script) and strandbench (quality).
add_library(strandcast_simcheck STATIC ${CMAKE_CURRENT_SOURCE_DIR}/support/sim_check.c
                                       ${CMAKE_CURRENT_SOURCE_DIR}/support/quality.c
                                       ${CMAKE_CURRENT_SOURCE_DIR}/support/vkpin.c)
target_include_directories(strandcast_simcheck PUBLIC ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(strandcast_simcheck PUBLIC strandcast PkgConfig::CMOCKA ${CMAKE_DL_LIBS})
foreach(t test_sim test_sim_rest test_sim_pbd test_sim_collide test_sim_volume test_sim_cancel test_sim_vk test_sim_vk_pbd test_sim_vk_sizes
          test_codec_sim test_quality test_groom test_sim_hm strandbench)
  target_link_libraries(${t} PRIVATE strandcast_simcheck)
endforeach()
