/* Test support: keep the Vulkan driver and validation layer loaded for LeakSanitizer. */
#ifndef TESTS_VKPIN_H
#define TESTS_VKPIN_H

/* The Vulkan loader unloads the driver (and layers) with the last instance; Mesa's and LLVM's
 * static caches then look like leaks to LeakSanitizer. Call once at the start of main, before
 * any Vulkan instance: it maps lavapipe and the validation layer for the life of the process,
 * leaving those caches reachable. A machine without lavapipe or the layer simply skips the pin. */
void vkpin_driver_libraries(void);

#endif
