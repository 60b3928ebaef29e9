/* sim_vk: Vulkan instance, validation messages, physical device choice, device and queue. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "sim_vk_internal.h"

#define VALIDATION_LAYER "VK_LAYER_KHRONOS_validation"

const char *sim_vk_result_name(VkResult r)
{
    switch (r) {
    case VK_SUCCESS: return "VK_SUCCESS";
    case VK_NOT_READY: return "VK_NOT_READY";
    case VK_TIMEOUT: return "VK_TIMEOUT";
    case VK_INCOMPLETE: return "VK_INCOMPLETE";
    case VK_ERROR_OUT_OF_HOST_MEMORY: return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY: return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED: return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST: return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_MEMORY_MAP_FAILED: return "VK_ERROR_MEMORY_MAP_FAILED";
    case VK_ERROR_LAYER_NOT_PRESENT: return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT: return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_FEATURE_NOT_PRESENT: return "VK_ERROR_FEATURE_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER: return "VK_ERROR_INCOMPATIBLE_DRIVER (no Vulkan driver found)";
    case VK_ERROR_TOO_MANY_OBJECTS: return "VK_ERROR_TOO_MANY_OBJECTS";
    case VK_ERROR_FORMAT_NOT_SUPPORTED: return "VK_ERROR_FORMAT_NOT_SUPPORTED";
    case VK_ERROR_FRAGMENTED_POOL: return "VK_ERROR_FRAGMENTED_POOL";
    case VK_ERROR_OUT_OF_POOL_MEMORY: return "VK_ERROR_OUT_OF_POOL_MEMORY";
    case VK_ERROR_INVALID_SHADER_NV: return "VK_ERROR_INVALID_SHADER_NV";
    default: return "VK_ERROR_UNKNOWN";
    }
}

core_status sim_vk_check(VkResult r, const char *what, core_err *err)
{
    if (r == VK_SUCCESS) return CORE_OK;
    return core_fail(err, CORE_EBACKEND, "vulkan: %s failed: %s (%d)", what, sim_vk_result_name(r), (int)r);
}

bool sim_vk_is_hardware(VkPhysicalDeviceType type)
{
    return type == VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU || type == VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU ||
           type == VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU;
}

void sim_vk_name(sim_vk_ctx *c, VkObjectType type, uint64_t handle, const char *name)
{
    if (!c->set_name || !handle) return;
    VkDebugUtilsObjectNameInfoEXT info = {
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_OBJECT_NAME_INFO_EXT,
        .objectType = type,
        .objectHandle = handle,
        .pObjectName = name,
    };
    /* naming is a debugging aid: a failure changes nothing */
    (void)c->set_name(c->device, &info);
}

/* Validation and driver messages go to the log; errors are counted for the tests. */
static VKAPI_ATTR VkBool32 VKAPI_CALL debug_cb(VkDebugUtilsMessageSeverityFlagBitsEXT severity,
                                               VkDebugUtilsMessageTypeFlagsEXT types,
                                               const VkDebugUtilsMessengerCallbackDataEXT *data, void *user)
{
    (void)types;
    sim_vk_ctx *c = user;
    const char *msg = data && data->pMessage ? data->pMessage : "(no message)";
    if (severity & VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT) {
        c->validation_errors++;
        core_log(CORE_LOG_ERROR, "sim_vk", "validation: %s", msg);
    } else {
        core_log(CORE_LOG_WARN, "sim_vk", "validation: %s", msg);
    }
    return VK_FALSE;
}

static bool has_layer(const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceLayerProperties(&n, NULL) != VK_SUCCESS || n == 0) return false;
    VkLayerProperties *props = calloc(n, sizeof *props);
    if (!props) return false;
    bool found = false;
    if (vkEnumerateInstanceLayerProperties(&n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++) found = strcmp(props[i].layerName, name) == 0;
    free(props);
    return found;
}

static bool has_instance_ext(const char *name)
{
    uint32_t n = 0;
    if (vkEnumerateInstanceExtensionProperties(NULL, &n, NULL) != VK_SUCCESS || n == 0) return false;
    VkExtensionProperties *props = calloc(n, sizeof *props);
    if (!props) return false;
    bool found = false;
    if (vkEnumerateInstanceExtensionProperties(NULL, &n, props) == VK_SUCCESS)
        for (uint32_t i = 0; i < n && !found; i++) found = strcmp(props[i].extensionName, name) == 0;
    free(props);
    return found;
}

static core_status create_instance(sim_vk_ctx *c, bool want_validation, core_err *err)
{
    bool validation = want_validation && has_layer(VALIDATION_LAYER);
    bool debug_utils = validation && has_instance_ext(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
    if (want_validation && !validation)
        core_log(CORE_LOG_WARN, "sim_vk", "validation requested but %s is not installed (Debian: vulkan-validationlayers)",
                 VALIDATION_LAYER);
    const char *layers[] = { VALIDATION_LAYER };
    const char *exts[] = { VK_EXT_DEBUG_UTILS_EXTENSION_NAME };
    VkApplicationInfo app = {
        .sType = VK_STRUCTURE_TYPE_APPLICATION_INFO,
        .pApplicationName = "strandcast",
        .applicationVersion = VK_MAKE_API_VERSION(0, 0, 1, 0),
        .pEngineName = "strandcast",
        .apiVersion = VK_API_VERSION_1_1,
    };
    VkDebugUtilsMessengerCreateInfoEXT dbg = {
        .sType = VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT,
        .messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT,
        .messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                       VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT,
        .pfnUserCallback = debug_cb,
        .pUserData = c,
    };
    VkInstanceCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO,
        .pNext = debug_utils ? &dbg : NULL,
        .pApplicationInfo = &app,
        .enabledLayerCount = validation ? 1u : 0u,
        .ppEnabledLayerNames = layers,
        .enabledExtensionCount = debug_utils ? 1u : 0u,
        .ppEnabledExtensionNames = exts,
    };
    core_status st = sim_vk_check(vkCreateInstance(&ci, NULL, &c->instance), "vkCreateInstance", err);
    if (st != CORE_OK) return st;
    c->validation = validation;
    if (!debug_utils) return CORE_OK;
    PFN_vkCreateDebugUtilsMessengerEXT create_messenger =
        (PFN_vkCreateDebugUtilsMessengerEXT)vkGetInstanceProcAddr(c->instance, "vkCreateDebugUtilsMessengerEXT");
    c->destroy_messenger =
        (PFN_vkDestroyDebugUtilsMessengerEXT)vkGetInstanceProcAddr(c->instance, "vkDestroyDebugUtilsMessengerEXT");
    c->set_name = (PFN_vkSetDebugUtilsObjectNameEXT)vkGetInstanceProcAddr(c->instance, "vkSetDebugUtilsObjectNameEXT");
    if (!create_messenger || !c->destroy_messenger) return CORE_OK;
    return sim_vk_check(create_messenger(c->instance, &dbg, NULL, &c->messenger), "vkCreateDebugUtilsMessengerEXT", err);
}

/* The compute queue family of phys, or UINT32_MAX when it has none. */
static uint32_t compute_family(VkPhysicalDevice phys)
{
    uint32_t n = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &n, NULL);
    VkQueueFamilyProperties *fam = calloc(n ? n : 1, sizeof *fam);
    if (!fam) return UINT32_MAX;
    vkGetPhysicalDeviceQueueFamilyProperties(phys, &n, fam);
    uint32_t best = UINT32_MAX;
    for (uint32_t i = 0; i < n; i++) {
        if (!(fam[i].queueFlags & VK_QUEUE_COMPUTE_BIT) || fam[i].queueCount == 0) continue;
        /* prefer a family that also writes timestamps */
        if (best == UINT32_MAX || (fam[i].timestampValidBits && !fam[best].timestampValidBits)) best = i;
    }
    free(fam);
    return best;
}

static int type_rank(VkPhysicalDeviceType t)
{
    switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU: return 4;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU: return 3;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU: return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU: return 1;
    default: return 0;
    }
}

static core_status usable(VkPhysicalDevice phys, uint32_t index, core_err *err)
{
    VkPhysicalDeviceProperties props;
    vkGetPhysicalDeviceProperties(phys, &props);
    if (props.apiVersion < VK_API_VERSION_1_1)
        return core_fail(err, CORE_EUNSUPPORTED, "vulkan: device %u (%s) supports only Vulkan %u.%u, 1.1 is needed",
                         index, props.deviceName, VK_API_VERSION_MAJOR(props.apiVersion),
                         VK_API_VERSION_MINOR(props.apiVersion));
    if (compute_family(phys) == UINT32_MAX)
        return core_fail(err, CORE_EUNSUPPORTED, "vulkan: device %u (%s) has no compute queue", index, props.deviceName);
    return CORE_OK;
}

/* Picks a physical device as documented for sim_vk_probe. */
static core_status pick_device(VkInstance inst, int desc_device, VkPhysicalDevice *out, uint32_t *index,
                               uint32_t *count, core_err *err)
{
    if (desc_device < 0)
        return core_fail(err, CORE_EINVAL, "vulkan: device %d: the index must be 0 (automatic) or >= 1", desc_device);
    uint32_t n = 0;
    core_status st = sim_vk_check(vkEnumeratePhysicalDevices(inst, &n, NULL), "vkEnumeratePhysicalDevices", err);
    if (st != CORE_OK) return st;
    *count = n;
    if (n == 0) return core_fail(err, CORE_EBACKEND, "vulkan: no physical device (install a driver, e.g. mesa-vulkan-drivers)");
    VkPhysicalDevice *devs = calloc(n, sizeof *devs);
    if (!devs) return core_fail(err, CORE_ENOMEM, "vulkan: out of memory listing devices");
    VkResult r = vkEnumeratePhysicalDevices(inst, &n, devs);
    if (r != VK_SUCCESS && r != VK_INCOMPLETE) {
        free(devs);
        return sim_vk_check(r, "vkEnumeratePhysicalDevices", err);
    }
    if (desc_device > 0) {
        uint32_t want = (uint32_t)desc_device - 1;
        if (want >= n) {
            free(devs);
            return core_fail(err, CORE_EINVAL, "vulkan: device %d requested but only %u device(s) present", desc_device, n);
        }
        st = usable(devs[want], want, err);
        if (st == CORE_OK) {
            *out = devs[want];
            *index = want;
        }
        free(devs);
        return st;
    }
    int best_rank = -1;
    core_err why = { "" };
    for (uint32_t i = 0; i < n; i++) {
        if (usable(devs[i], i, &why) != CORE_OK) continue;
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(devs[i], &props);
        int rank = type_rank(props.deviceType);
        if (rank > best_rank) {
            best_rank = rank;
            *out = devs[i];
            *index = i;
        }
    }
    free(devs);
    if (best_rank < 0) return core_fail(err, CORE_EUNSUPPORTED, "%s", why.msg);
    return CORE_OK;
}

core_status sim_vk_probe(int device, sim_vk_probe_info *info, core_err *err)
{
    memset(info, 0, sizeof *info);
    sim_vk_ctx c;
    memset(&c, 0, sizeof c);
    core_status st = create_instance(&c, false, err);
    if (st == CORE_OK) st = pick_device(c.instance, device, &c.phys, &info->index, &info->ndevices, err);
    if (st == CORE_OK) {
        VkPhysicalDeviceProperties props;
        vkGetPhysicalDeviceProperties(c.phys, &props);
        snprintf(info->device_name, sizeof info->device_name, "%s", props.deviceName);
        info->hardware = sim_vk_is_hardware(props.deviceType);
    }
    sim_vk_ctx_destroy(&c);
    return st;
}

static core_status create_device(sim_vk_ctx *c, core_err *err)
{
    float prio = 1.0f;
    VkDeviceQueueCreateInfo qci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO,
        .queueFamilyIndex = c->queue_family,
        .queueCount = 1,
        .pQueuePriorities = &prio,
    };
    VkDeviceCreateInfo ci = {
        .sType = VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO,
        .queueCreateInfoCount = 1,
        .pQueueCreateInfos = &qci,
    };
    core_status st = sim_vk_check(vkCreateDevice(c->phys, &ci, NULL, &c->device), "vkCreateDevice", err);
    if (st != CORE_OK) return st;
    vkGetDeviceQueue(c->device, c->queue_family, 0, &c->queue);
    VkCommandPoolCreateInfo pci = {
        .sType = VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO,
        .flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT,
        .queueFamilyIndex = c->queue_family,
    };
    st = sim_vk_check(vkCreateCommandPool(c->device, &pci, NULL, &c->pool), "vkCreateCommandPool", err);
    if (st != CORE_OK) return st;
    sim_vk_name(c, VK_OBJECT_TYPE_QUEUE, (uint64_t)(uintptr_t)c->queue, "sim_vk compute queue");
    sim_vk_name(c, VK_OBJECT_TYPE_COMMAND_POOL, (uint64_t)c->pool, "sim_vk command pool");
    return CORE_OK;
}

core_status sim_vk_ctx_init(sim_vk_ctx *c, int desc_device, bool want_validation, core_err *err)
{
    memset(c, 0, sizeof *c);
    uint32_t index = 0, count = 0;
    core_status st = create_instance(c, want_validation, err);
    if (st == CORE_OK) st = pick_device(c->instance, desc_device, &c->phys, &index, &count, err);
    if (st != CORE_OK) {
        sim_vk_ctx_destroy(c);
        return st;
    }
    vkGetPhysicalDeviceProperties(c->phys, &c->props);
    vkGetPhysicalDeviceMemoryProperties(c->phys, &c->mem);
    c->queue_family = compute_family(c->phys);
    uint32_t nfam = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(c->phys, &nfam, NULL);
    VkQueueFamilyProperties *fam = calloc(nfam ? nfam : 1, sizeof *fam);
    if (!fam) {
        sim_vk_ctx_destroy(c);
        return core_fail(err, CORE_ENOMEM, "vulkan: out of memory listing queue families");
    }
    vkGetPhysicalDeviceQueueFamilyProperties(c->phys, &nfam, fam);
    uint32_t bits = c->queue_family < nfam ? fam[c->queue_family].timestampValidBits : 0;
    free(fam);
    c->timestamps = bits > 0 && c->props.limits.timestampPeriod > 0.0f;
    c->timestamp_mask = bits >= 64 ? ~0ull : ((1ull << bits) - 1ull);
    st = create_device(c, err);
    if (st != CORE_OK) {
        sim_vk_ctx_destroy(c);
        return st;
    }
    core_log(CORE_LOG_INFO, "sim_vk", "device %u of %u: %s (%s)%s", index, count, c->props.deviceName,
             sim_vk_is_hardware(c->props.deviceType) ? "GPU" : "CPU device",
             c->validation ? ", validation on" : "");
    return CORE_OK;
}

void sim_vk_ctx_destroy(sim_vk_ctx *c)
{
    if (c->device) {
        (void)vkDeviceWaitIdle(c->device);
        if (c->pool) vkDestroyCommandPool(c->device, c->pool, NULL);
        vkDestroyDevice(c->device, NULL);
    }
    if (c->messenger && c->destroy_messenger) c->destroy_messenger(c->instance, c->messenger, NULL);
    if (c->instance) vkDestroyInstance(c->instance, NULL);
    memset(c, 0, sizeof *c);
}
