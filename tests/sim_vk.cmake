# tests: the Vulkan backend's benchmark-size test steps grooms up to 16,384 x 64 on lavapipe
# (minutes on a 2-core machine; far longer under ASan with the validation layer): release tree only.
set_tests_properties(test_sim_vk_sizes PROPERTIES LABELS no_asan)
