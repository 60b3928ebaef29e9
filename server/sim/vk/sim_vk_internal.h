/* sim_vk: internal types shared by the Vulkan backend's files (context, buffers, pipelines). */
#ifndef SIM_VK_SIM_VK_INTERNAL_H
#define SIM_VK_SIM_VK_INTERNAL_H

#include <stdbool.h>
#include <stdint.h>
#include <vulkan/vulkan.h>

#include "../../core/core.h"
#include "../../core/groom_types.h"
#include "../sim.h"
#include "../sim_step.h"
#include "sim_vk.h"

/* Steps that may be in flight at once (each has its own command buffer, fence, frame
 * parameters and timestamp queries). */
#define SIM_VK_FRAMES 2
/* Sizes shared with shaders/sim_common.glsl. */
#define SIM_VK_WG 64         /* workgroup size of the particle-parallel passes */
#define SIM_VK_SCAN_BLOCK 512 /* cells per scan workgroup (256 threads x 2) */

/* ---- context: instance, device, queue (sim_vk_ctx.c) ------------------------------- */

typedef struct sim_vk_ctx {
    VkInstance instance;
    VkDebugUtilsMessengerEXT messenger;
    PFN_vkDestroyDebugUtilsMessengerEXT destroy_messenger;
    PFN_vkSetDebugUtilsObjectNameEXT set_name; /* NULL without VK_EXT_debug_utils */
    VkPhysicalDevice phys;
    VkPhysicalDeviceProperties props;
    VkPhysicalDeviceMemoryProperties mem;
    uint32_t queue_family;
    VkDevice device;
    VkQueue queue;
    VkCommandPool pool;
    bool timestamps;          /* the queue can write timestamps */
    uint64_t timestamp_mask;  /* valid bits of a timestamp */
    bool validation;          /* VK_LAYER_KHRONOS_validation enabled */
    uint32_t validation_errors; /* error messages seen by the debug messenger */
    VkDeviceSize buffer_bytes; /* the sizes of the buffers sim_vk_buf_create made, less those destroyed */
} sim_vk_ctx;

/* Opens an instance (with the validation layer and debug names when want_validation and
 * they are installed), picks a physical device (desc_device as in sim_vk_probe), creates a
 * device with one compute queue and a command pool. On failure everything made so far is
 * destroyed and err names the Vulkan call and its result. Sim thread. */
core_status sim_vk_ctx_init(sim_vk_ctx *c, int desc_device, bool want_validation, core_err *err);

/* Destroys what sim_vk_ctx_init made (waits for the device to be idle); safe on a zeroed ctx. */
void sim_vk_ctx_destroy(sim_vk_ctx *c);

/* Turns a VkResult into CORE_OK or CORE_EBACKEND with "what: VK_ERROR_...". Pure. */
core_status sim_vk_check(VkResult r, const char *what, core_err *err);

/* Stable name of a VkResult ("VK_ERROR_OUT_OF_DEVICE_MEMORY", ...); static storage. */
const char *sim_vk_result_name(VkResult r);

/* Gives a Vulkan object a debug name when debug utils are on; a no-op otherwise. */
void sim_vk_name(sim_vk_ctx *c, VkObjectType type, uint64_t handle, const char *name);

/* Whether the device is a hardware GPU (discrete, integrated or virtual). Pure. */
bool sim_vk_is_hardware(VkPhysicalDeviceType type);

/* ---- buffers and transfers (sim_vk_mem.c) ------------------------------------------ */

typedef struct sim_vk_buf {
    VkBuffer buf;
    VkDeviceMemory mem;
    VkDeviceSize size;
    void *map; /* persistent mapping of host-visible buffers, else NULL */
} sim_vk_buf;

typedef enum sim_vk_mem_kind {
    SIM_VK_MEM_DEVICE = 0, /* device-local, not mapped */
    SIM_VK_MEM_UPLOAD,     /* host-visible, coherent, mapped: written by the host */
    SIM_VK_MEM_READBACK    /* host-visible, coherent (cached when possible), mapped */
} sim_vk_mem_kind;

/* Creates a buffer of size bytes (rounded up to 16) with its own memory. Storage buffers are
 * checked against the device's maxStorageBufferRange. Sim thread. */
core_status sim_vk_buf_create(sim_vk_ctx *c, sim_vk_buf *b, VkDeviceSize size, VkBufferUsageFlags usage,
                              sim_vk_mem_kind kind, const char *name, core_err *err);

/* Frees the buffer and its memory; safe on a zeroed buffer. */
void sim_vk_buf_destroy(sim_vk_ctx *c, sim_vk_buf *b);

/* A command buffer + fence for blocking one-off work (uploads, readbacks, create-time passes). */
typedef struct sim_vk_once {
    VkCommandBuffer cmd;
    VkFence fence;
} sim_vk_once;

core_status sim_vk_once_init(sim_vk_ctx *c, sim_vk_once *o, core_err *err);
void sim_vk_once_destroy(sim_vk_ctx *c, sim_vk_once *o);
/* Resets and begins o->cmd. */
core_status sim_vk_once_begin(sim_vk_ctx *c, sim_vk_once *o, core_err *err);
/* Ends o->cmd, submits it after everything submitted before and waits for it. */
core_status sim_vk_once_submit_wait(sim_vk_ctx *c, sim_vk_once *o, core_err *err);

/* Records a full memory barrier from compute/transfer writes to compute/transfer/host access. */
void sim_vk_barrier(VkCommandBuffer cmd);


/* ---- SPIR-V patching (sim_vk_spirv.c) ------------------------------------------------ */

/* Copies a SPIR-V module (words 32-bit words) into *out (malloc'd, caller frees) with every
 * float add, subtract, multiply, divide, negate and dot product decorated NoContraction, so
 * that the driver keeps the C backend's rounding (no FMA fusion). CORE_EFORMAT for a module
 * that does not parse. Pure. */
core_status sim_vk_spirv_exact(const uint32_t *code, size_t words, uint32_t **out, size_t *out_words, core_err *err);

/* ---- descriptors and pipelines (sim_vk_pipe.c) ------------------------------------- */

/* Descriptor bindings of the single set every shader uses (shaders/sim_common.glsl). */
typedef enum sim_vk_binding {
    SIM_VK_B_FRAME = 0, SIM_VK_B_X, SIM_VK_B_V, SIM_VK_B_A, SIM_VK_B_REST, SIM_VK_B_STRAND,
    SIM_VK_B_GRID, SIM_VK_B_COUNT, SIM_VK_B_START, SIM_VK_B_BLOCK, SIM_VK_B_CELL_OF,
    SIM_VK_B_ORDER, SIM_VK_B_SX, SIM_VK_B_SV, SIM_VK_B_RHO, SIM_VK_B_PRESS, SIM_VK_B_NBR,
    SIM_VK_B_NNBR, SIM_VK_B_STATS, SIM_VK_B_SDF, SIM_VK_B_PBD, SIM_VK_B_FLOOR, SIM_VK_B_XE, SIM_VK_B_AF,
    SIM_VK_NBINDINGS
} sim_vk_binding;

/* The compute pipelines, one per shader entry. */
typedef enum sim_vk_pipe_id {
    SIM_VK_P_CHAIN = 0,     /* the chain pass, one level per dispatch */
    SIM_VK_P_SPH_BOUNDS,
    SIM_VK_P_SPH_GRID,
    SIM_VK_P_SPH_COUNT,
    SIM_VK_P_SCAN_BLOCKS,
    SIM_VK_P_SCAN_SUMS,
    SIM_VK_P_SCAN_ADD,
    SIM_VK_P_SPH_SCATTER,
    SIM_VK_P_SPH_CELLSORT,
    SIM_VK_P_SPH_DENSITY,
    SIM_VK_P_SPH_FORCE,
    SIM_VK_P_PBD,           /* one PBD substep, one thread per strand */
    SIM_VK_NPIPES
} sim_vk_pipe_id;

/* Push constants of every pipeline (16 bytes). */
typedef struct sim_vk_push {
    uint32_t substep;
    uint32_t level;
    uint32_t arg0;
    uint32_t arg1;
} sim_vk_push;

/* Per-pipeline specialization: the workgroup size and the compile-time sizes. */
typedef struct sim_vk_spec {
    uint32_t wg;      /* constant_id 0: local_size_x */
    uint32_t ns;      /* constant_id 1: strands */
    uint32_t nv;      /* constant_id 2: vertices per strand */
} sim_vk_spec;

typedef struct sim_vk_pipes {
    VkDescriptorSetLayout set_layout;
    VkPipelineLayout layout;
    VkDescriptorPool pool;
    VkDescriptorSet sets[SIM_VK_FRAMES];
    VkPipeline pipe[SIM_VK_NPIPES];
    uint32_t wg[SIM_VK_NPIPES]; /* workgroup size of each pipeline */
} sim_vk_pipes;

/* Creates the set layout, pipeline layout, descriptor pool and sets, and every pipeline with
 * the sizes of this solver. Sim thread. */
core_status sim_vk_pipes_init(sim_vk_ctx *c, sim_vk_pipes *p, uint32_t ns, uint32_t nv, core_err *err);
/* Points binding b of every set (or only of set `frame` when frame >= 0) at buffer buf. */
void sim_vk_pipes_bind(sim_vk_ctx *c, sim_vk_pipes *p, int frame, sim_vk_binding b, const sim_vk_buf *buf);
void sim_vk_pipes_destroy(sim_vk_ctx *c, sim_vk_pipes *p);

/* ---- per-step parameters (sim_vk_frame.c), layout of shaders/sim_common.glsl ------- */

#define SIM_VK_FLAG_SHAPE 1u
#define SIM_VK_FLAG_SPH 2u
#define SIM_VK_FLAG_COLLISIONS 4u

typedef struct sim_vk_gxf {
    float pos[4];
    float rot[4];
} sim_vk_gxf;

typedef struct sim_vk_gcollider {
    float a[4];        /* w: kind */
    float b[4];        /* w: radius */
    float lo[4], hi[4]; /* world bounding box (culling) */
    float m[3][4];     /* ellipsoid: rows of world offset -> unit-sphere coordinates */
    float nrm[3][4];   /* ellipsoid: rows of unit-sphere coordinates -> world offset */
} sim_vk_gcollider;

/* Per substep: the colliders' motion and the distance grid's placement (sim_step_desc). */
typedef struct sim_vk_gsub {
    float carry[3][4];     /* rows: matrix (xyz) and translation (w) */
    float to_head[3][4];   /* rows: world offset -> head frame */
    float from_head[3][4]; /* rows: head-frame direction -> world */
    float pos[4];          /* head position */
    float lo[4], hi[4];    /* world box of the grid */
} sim_vk_gsub;

typedef struct sim_vk_frame {
    float accel[4];    /* xyz: gravity + wind; w: keep (internal damping per substep) */
    float dt_k, inv_dt_k, dftl, h;
    float h2, inv_h2, inv_h, kp;
    float mu_dt, inv_step_dt, inv_rho0, grow;
    uint32_t substeps, ncolliders, flags, cap;
    float drag_keep, friction, sph_keep, sph_inv_since;
    float hair_friction, ftl_damp, pad[2];
    sim_vk_gxf head[SIM_MAX_SUBSTEPS];
    sim_vk_gcollider col[SIM_MAX_SUBSTEPS * SIM_MAX_COLLIDERS];
    uint32_t sdf_dims[4];  /* w: 1 when the grid collides this step */
    float sdf_origin[4];   /* w: cell */
    sim_vk_gsub sub[SIM_MAX_SUBSTEPS];
    /* followed by nverts pairs (s_g, s_l) */
} sim_vk_frame;

/* Bytes of the frame parameters for nv levels. Pure. */
size_t sim_vk_frame_size(uint32_t nv);

/* What a frame is computed from. */
typedef struct sim_vk_frame_in {
    const sim_params *params;
    const sim_step_desc *step; /* sim_step_plan of this step */
    uint32_t nv;
    float max_segment;     /* longest rest segment (collider culling margin) */
    bool pbd;              /* per level (kg, kl, b, 0) of the PBD solver instead of the shape weights */
} sim_vk_frame_in;

/* Fills out (sim_vk_frame_size(in->nv) bytes) with the step description in the layout of
 * sim_common.glsl, plus the per-level stiffness: the DFTL solver's shape weights, or with pbd
 * the PBD solver's stiffnesses (sim_pbd_stiffness) and its spring damping
 * b = sim_step_shape_damping(h). Pure. */
void sim_vk_frame_fill(const sim_vk_frame_in *in, void *out);

/* ---- the backend instance (sim_vk.c) and its command recording (sim_vk_record.c) ---- */

/* Timestamped stages of a step (stage i lies between timestamps i and i + 1). */
typedef enum sim_vk_stage {
    SIM_VK_S_GRID = 0, /* bounding box, grid, cell counts */
    SIM_VK_S_SORT,     /* prefix sum, scatter, stable in-cell sort, gather */
    SIM_VK_S_DENSITY,  /* neighbour search, density, pressure */
    SIM_VK_S_FORCE,    /* pressure + viscosity accelerations */
    SIM_VK_S_CHAIN,    /* all substeps of the chain pass (the PBD substeps with that solver) */
    SIM_VK_NSTAGES
} sim_vk_stage;

typedef struct sim_vk_slot {
    VkCommandBuffer cmd;
    VkFence fence;
    VkQueryPool queries;  /* SIM_VK_NSTAGES + 1 timestamps, or null */
    sim_vk_buf frame;     /* frame parameters (host-written) */
    bool pending;         /* submitted, results not collected yet */
    unsigned long long submit_ns;
} sim_vk_slot;

typedef struct sim_vk {
    sim_vk_ctx ctx;
    sim_vk_pipes pipes;
    sim_step_desc step;   /* the step being recorded (sim_step_plan) */
    uint32_t ns, nv;
    size_t n;
    sim_params params;
    core_xform head, prev_head;
    uint32_t ncolliders;
    core_collider colliders[CORE_MAX_COLLIDERS];
    uint32_t *perm;       /* internal strand -> groom strand (sim_strand_order, shared with the C backend) */
    float *rest;          /* host copy, level-major xyz in internal strand order (reset) */
    float *host_tmp;      /* 3n floats of conversion space */
    core_sdf sdf;         /* the groom's distance grid: dims, origin, cell (sdf.d stays NULL; the
                             samples live in sdf_buf); has_sdf says whether there is one */
    bool has_sdf;
    size_t cells_cap;     /* SPH hash buckets (a power of two) */
    uint32_t nbr_cap;     /* neighbour slots per particle NBR holds */
    float rho_rest;
    bool rho_rest_valid;
    sim_sph_clock sph_clock; /* whether A holds an SPH acceleration (its low-pass state), and its age */
    float max_segment;    /* longest rest segment */
    float sph_auto_h;     /* the groom's automatic SPH smoothing length (sim_sph_auto_radius) */
    sim_vk_buf x, v, a, rest_buf, strand, grid, count, start, block, cell_of, order, sx, sv, rho, press, nbr, nnbr;
    sim_vk_buf xe;        /* DEVICE: positions at the last SPH evaluation (the viscosity's motion) */
    sim_vk_buf af;        /* DEVICE: the hair-hair friction's held acceleration (included in a) */
    sim_vk_buf stats_buf; /* READBACK: nan counter */
    sim_vk_buf sdf_buf;   /* DEVICE: the distance samples (16 unused bytes without a grid) */
    sim_vk_buf pbd;       /* DEVICE: the PBD substep's scratch, 30 floats per vertex (16 unused
                             bytes with the DFTL solver) */
    sim_vk_buf floor_buf; /* DEVICE: the contact floors (sim_groom_contact_floor), level-major */
    sim_vk_buf staging;   /* READBACK: 6n floats for uploads and readbacks */
    sim_vk_once once;
    sim_vk_slot slots[SIM_VK_FRAMES];
    uint64_t submitted;   /* steps submitted since create */
    uint64_t pbd_segments; /* PBD segments x substeps submitted since the last reset (the
                              denominator of sim_stats.pbd_stretch_mean) */
    sim_stats stats;
    core_status broken;   /* sticky: a failed submit/wait leaves the device unusable */
    core_err broken_err;
} sim_vk;

/* How an SPH pass gets its neighbours. */
typedef enum sim_vk_sph_mode {
    SIM_VK_SPH_REST,    /* rest-density pass: grid, sort, search on REST with zero velocities */
    SIM_VK_SPH_STEP     /* grid, sort, search on the current state, then forces: every step, so
                           the neighbours are those within h now, as the C backend's skin lists
                           give them */
} sim_vk_sph_mode;

/* Records an SPH pass into cmd with descriptor set `set`. Timestamps go to queries (may be
 * VK_NULL_HANDLE) at indices SIM_VK_S_* + 1 (every stage gets one). */
void sim_vk_record_sph(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set, sim_vk_sph_mode mode, VkQueryPool queries);

/* Records the chain pass for every substep (after the SPH passes). */
void sim_vk_record_chain(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set);

/* Records the PBD substeps of a step (solver PBD): one dispatch per substep. */
void sim_vk_record_pbd(sim_vk *s, VkCommandBuffer cmd, VkDescriptorSet set);

#endif
