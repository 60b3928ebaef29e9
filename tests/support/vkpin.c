/* Test support: keep the Vulkan driver and validation layer loaded for LeakSanitizer. */
#include "vkpin.h"

#include <dlfcn.h>

void vkpin_driver_libraries(void)
{
    (void)dlopen("libvulkan_lvp.so", RTLD_NOW | RTLD_NODELETE);
    (void)dlopen("libVkLayer_khronos_validation.so", RTLD_NOW | RTLD_NODELETE);
}
