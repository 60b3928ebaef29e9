/* sim_hm: the solver's state and the stages shared by its files; not public. */
#ifndef SIM_HM_SIM_HM_INTERNAL_H
#define SIM_HM_SIM_HM_INTERNAL_H

#include <stdint.h>
#include <string.h>

#include "../sim_step.h"
#include "sim_hm.h"

/* Baraff and Witkin's cloth elements on the hair mesh (create time): the triangles of every side
 * quad of a prism (between two layers, along the hair) and of every layer face, each with its rest
 * (u, v) frame (u along the hair on the side faces, along the face's first edge on the layer
 * faces), and the bends between side triangles sharing an edge. Their vertices are in the rows'. */
typedef struct sim_hm_cloth {
    uint32_t ntri, nbend;
    float *tri_c;       /* 4 per triangle: w_u = c0 (x1 - x0) + c1 (x2 - x0), w_v = c2 (x1 - x0) + c3 (x2 - x0) */
    float *tri_a;       /* rest area, m^2 */
    float *tri_s;       /* 3 per triangle: each condition's stiffness scale, 1 / |dC/dx|^2 at rest of its most moved vertex */
    float *bend_theta0; /* rest dihedral angle */
    float *bend_scale;  /* h1 h2 / 2: h the rest triangles' heights over the shared edge, m^2 */
    /* per step: each triangle's stretch terms' second derivative, kept under tension (it adds
     * (b_u cu_i cu_j + b_v cv_i cv_j) I to the block (i, j), cu and cv the coefficients of x_i in
     * w_u and w_v; the rest of it, -b g g^T / a^2, is in the rows' weights) */
    float *tri_b;       /* 2 per triangle: b_u, b_v */
} sim_hm_cloth;

/* The dampers (create time): pairs of vertices whose velocity relative to each other, less the
 * head's rigid motion, decays at hm_damping, along the pair and across it: every column segment,
 * layer edge, diagonal of a prism's side face and of a quad, and the columns' l, l + 2 pairs. */
typedef struct sim_hm_dampers {
    uint32_t n;
    uint32_t *a, *b;
    uint32_t *at; /* 2 per pair: the blocks (a, b) and (b, a) */
    float c;      /* per step: dt hm_damping, the pairs' weight in the system */
} sim_hm_dampers;

/* Corner tetrahedra (create time): rest volume and the force scale; vertices in the rows'. */
typedef struct sim_hm_tets {
    uint32_t n;
    float *v0;     /* rest volume, m^3 */
    float *scale;  /* |v0|^(2/3) / v0^2 */
} sim_hm_tets;

/* The conditions C of the implicit system, each a row of up to 4 vertices: 3 per triangle
 * (stretch along u, along v, shear), then 1 per bend, then 1 per tetrahedron (volume). Each
 * adds w g_j g_k^T to the system's block (v[j], v[k]) (Gauss-Newton: the second derivatives of
 * C dropped, the system SPD). */
typedef struct sim_hm_rows {
    uint32_t n, bend0, tet0; /* rows; the first bend's and tetrahedron's */
    uint32_t *v;             /* 4 per row; a triangle's 4th repeats its 3rd */
    uint8_t *nv;             /* vertices used: 3 or 4 */
    uint32_t *at;            /* 16 per row: the block (v[j], v[k]) at 4 j + k */
    float *g, *w;            /* per step: dC/dx (12 per row) and dt kd' + dt^2 k' */
} sim_hm_rows;

/* The mesh edges of the deformation minimization (A's rows) as each vertex's neighbours, and the
 * vertices' inverse degrees. */
typedef struct sim_hm_edges {
    uint32_t n;          /* edges */
    uint32_t *row, *nb;  /* vertex i's neighbours, ascending: nb[row[i]] .. nb[row[i + 1] - 1] */
    float *inv_degree;   /* per vertex: 1 / degree, 0 for none */
} sim_hm_edges;

/* The least rate, 1/s, at which the mesh's velocity relative to the head's rigid motion decays:
 * the pair dampers act on pairs of vertices whose forces cancel in a rigid swing of the mesh
 * about its roots, so only the root prisms' dampers and the air drag damp that swing, and at
 * air_drag 0 the meshes still swung 3.7-4 s after the violent script (bound 3). Air drag (relative
 * to still air, the same at rest) counts towards it; the rest acts relative to the head. */
#define SIM_HM_SWING_DAMPING 2.0f

/* The most air drag, 1/s, the mesh feels: about the critical damping of its swing about the roots
 * under gravity (2 sqrt(g / L) is 12 for a pendulum 0.27 m long at 9.81 m/s^2), past which more drag only over-damps its elastic
 * return to the rest shape, which then creeps back: air_drag 20 rested 3.10-3.43 s after the
 * violent script (bound 3), 16 up to 3.40 s, 12 at most 2.72 s. Taking only the drag on the
 * mesh's motion relative to the head down to it (the hair carried by the head feeling all of
 * air_drag) left the mesh on the distance grid chattering 0.02-0.04 mm a frame at 16 and 20. */
#define SIM_HM_DRAG_CAP 12.0f

/* A vertex's contact with a collider for the next implicit solve (sim_hm.stick). */
typedef enum sim_hm_contact {
    SIM_HM_FREE = 0,    /* none */
    SIM_HM_RESTING = 1, /* friction stopped it: held to the collider */
    SIM_HM_SLIDING = 2  /* only its velocity along the normal is held (sim_hm_filter_sliding) */
} sim_hm_contact;

/* Floats per block of the system's matrix: 3 columns of 3, element (r, c) at 3 c + r (packed: a
 * quarter less to stream per CG iteration than columns of 4, 1.4 MB at 2,304 vertices, within a
 * core's 2 MB L2). */
#define SIM_HM_BLOCK 9

/* 4 floats as one value (GCC/Clang vector extensions, may alias float): a block's column read with
 * the next float (which the lane 3 of a product then carries and nobody reads). */
typedef float sim_hm_v4 __attribute__((vector_size(16), may_alias));

/* Adds the columns c0, c1, c2 (lanes 0-2) to the block at b in two 4-float and one scalar
 * additions (each element's addition as a column's would be). */
static inline void sim_hm_block_add(float *b, sim_hm_v4 c0, sim_hm_v4 c1, sim_hm_v4 c2)
{
    sim_hm_v4 lo, hi;
    memcpy(&lo, b, sizeof lo), memcpy(&hi, b + 4, sizeof hi);
    lo += (sim_hm_v4){ c0[0], c0[1], c0[2], c1[0] };
    hi += (sim_hm_v4){ c1[1], c1[2], c2[0], c2[1] };
    memcpy(b, &lo, sizeof lo), memcpy(b + 4, &hi, sizeof hi);
    b[8] += c2[2];
}

/* The implicit system A as a block-sparse matrix: 3x3 blocks (SIM_HM_BLOCK floats) in rows of
 * ascending columns over the vertex pairs that a condition row joins (pattern fixed at create,
 * values assembled every substep). */
typedef struct sim_hm_bsr {
    uint32_t n, nnz;   /* block rows (vertices), blocks */
    uint32_t *row;     /* n + 1: each row's first block */
    uint32_t *col;     /* nnz: the blocks' columns */
    uint32_t *diag;    /* n: each row's diagonal block */
    float *val;        /* SIM_HM_BLOCK nnz + 3 (the last column's read of 4 floats) */
} sim_hm_bsr;

typedef struct sim_hm {
    uint32_t ncols, nlayers, n; /* n = ncols * nlayers vertices */
    core_hairmesh mesh;         /* faces, guides, rest positions (head frame) */
    uint32_t nstrands, nverts;
    sim_params p;
    sim_groom_info ginfo;
    core_collider colliders[CORE_MAX_COLLIDERS];
    core_sdf *sdf;              /* owned copy, NULL = none */
    core_xform head, prev_head;
    float *x, *v;               /* 3n, world */
    float *xs, *xp;             /* 3n: positions at the substep's start, after the implicit step */
    float *rhs, *vn, *z;        /* 3n: right-hand side, the substep's new velocity, the head's rigid
                                 * velocity at each vertex (the dampers' reference, the free rows' cold
                                 * start, the held contacts' velocity; the roots' prescribed velocity) */
    float *dvp;                 /* 3n: the last solve's velocity change vn - v (the warm start's) */
    float diag;                 /* the system's diagonal: 1 + dt max(min(air_drag, SIM_HM_DRAG_CAP), SIM_HM_SWING_DAMPING) (unit masses) */
    float *pinv;                /* 6n: inverses of the system's diagonal blocks (xx yy zz xy xz yz), for the sweeps */
    float *r, *c, *q, *s, *w, *xh; /* 3n: CG scratch */
    uint8_t *fixed;             /* n: 0 free, 1 root, 2 in contact (held on the collider during the
                                 * implicit solve, or pushed by the collisions; held while minimizing) */
    uint8_t *stick;             /* n: a vertex's contact for the next implicit solve (sim_hm_contact) */
    float *normal;              /* 3n: a resting vertex's contact normal (world, turned with the head) */
    float *nrow;                /* 3 nnz: for a sliding vertex's row, n^T of each of its blocks before filtering */
    float *nrhs;                /* n: a sliding vertex's n . rhs before filtering */
    uint8_t *surface;           /* n: 1 = on the outer surface (collided) */
    float *push;                /* 3n: this substep's collision push of each vertex */
    sim_hm_cloth cloth;
    sim_hm_dampers damp;
    sim_hm_tets tets;
    sim_hm_rows rows;
    sim_hm_edges edges;
    sim_hm_bsr bsr;
    double stage_ms[4];
    uint64_t steps, nan_resets;
    double sim_time, last_step_ms;
} sim_hm;

/* Builds the cloth elements, tetrahedra, condition rows, edges and surface flags from h->mesh
 * (rest positions). */
core_status sim_hm_build(sim_hm *h, core_err *err);
/* Frees what sim_hm_build made. */
void sim_hm_build_free(sim_hm *h);

/* Forces at h->x, h->v (gravity and wind accel, air drag and SIM_HM_SWING_DAMPING, Baraff and
 * Witkin's stretch, shear and bend conditions with their dampers -kd' dC/dx dC/dt, the pair
 * dampers, both on the velocity less the head's rigid motion, h->z, which the caller fills;
 * volume) and the implicit system (I - dt df/dv - dt^2 df/dx) vn = v + dt f_e for substep
 * length dt (the new velocity vn; f_e the forces less the dampers' dt df/dv vn, which A carries,
 * so f_e keeps the dampers' head term): the same step as solving for the velocity
 * change dv = vn - v with right-hand side dt (f + dt df/dx v), but without that side's dt^2 df/dx v,
 * which for stiff elements is huge and almost cancelled by A dv, so that CG stopped at a relative
 * tolerance left errors of that size (the wavy and curly meshes exploded); and a CG stopped early
 * from the head's rigid velocity (sim_hm_cg) errs towards moving with the head instead of keeping
 * the old velocity's stiff part. Fills h->rhs, h->diag, h->pinv, h->bsr's blocks, the rows'
 * gradients and weights, the triangles' tension terms and the dampers' weight. */
void sim_hm_forces(sim_hm *h, const float accel[3], float dt);

/* The rest (u, v) frame of the triangle p0 p1 p2 (u: along projected onto its plane, v = n x u) as
 * the coefficients c of w_u and w_v (sim_hm_cloth.tri_c) and its area; false when degenerate. */
bool sim_hm_bw_rest_triangle(const float *p0, const float *p1, const float *p2, const float along[3], float c[4],
                             float *area);

/* The coefficients of x0, x1 and x2 in w_u (cu) and w_v (cv) of the triangle's rest frame c. */
void sim_hm_bw_coefficients(const float c[4], float cu[3], float cv[3]);

/* At x0 x1 x2: stretch C[0] = a (|w_u| - 1), C[1] = a (|w_v| - 1) and shear C[2] = a w_u . w_v
 * (BW98 eq. 10-11) and their gradients g[r] (3 per vertex). */
void sim_hm_bw_stretch_shear(const float *x0, const float *x1, const float *x2, const float c[4], float a, float C[3],
                             float g[3][9]);

/* The dihedral angle theta between the triangles (x1, x3, x4) and (x2, x4, x3) sharing the edge
 * x3 x4 (BW98 eq. 12: sin theta = (n2 x n1) . e, cos theta = n1 . n2; 0 when flat) and its
 * gradient (3 per vertex, x1 x2 x3 x4); false when a triangle or the edge is degenerate. */
bool sim_hm_bw_bend(const float *x1, const float *x2, const float *x3, const float *x4, float *theta, float g[12]);

/* Baraff and Witkin's partial constraint for the sliding vertices (h->stick SIM_HM_SLIDING, normal n = h->normal):
 * after sim_hm_forces, turns A vn = rhs into S A S vn + (I - S) vn = S (rhs - A P z) + P z with
 * S = I - n n^T and P = n n^T on those rows (I elsewhere), so the CG (unchanged, preconditioner
 * included, the system still SPD) keeps their velocity along n at the head's rigid z and leaves
 * them free along the surface. The rows of fixed vertices (the CG ignores them) keep A's and rhs's
 * values (release_contacts reads them). Call it after h->fixed is set. Keeps each filtered row's n^T A in h->nrow and n . rhs in h->nrhs
 * (the contact force along n is n^T A vn - n . rhs) and refreshes their h->pinv. */
void sim_hm_filter_sliding(sim_hm *h);

/* Builds h->bsr's pattern from the condition rows and the dampers (sim_hm_build calls it). */
core_status sim_hm_bsr_build(sim_hm *h, core_err *err);
/* Frees what sim_hm_bsr_build made. */
void sim_hm_bsr_free(sim_hm_bsr *m);

/* y = A x with the blocks sim_hm_forces assembled in m (the CG's product); x and y do not overlap. */
void sim_hm_bsr_apply(const sim_hm_bsr *m, const float *x, float *y);

/* y[v] = A x[v] for 3 vectors in one pass over the blocks (each as sim_hm_bsr_apply). */
void sim_hm_bsr_apply3(const sim_hm_bsr *m, const float *const x[3], float *const y[3]);

/* y = row i of A x (3 floats). */
void sim_hm_bsr_row_apply(const sim_hm_bsr *m, uint32_t i, const float *x, float y[3]);

/* With A = L + D + U (D its diagonal blocks, dinv their inverses as xx yy zz xy xz yz) restricted
 * to the rows where fixed[i] == 0 (the others' t and u are 0 and their columns are ignored): the
 * forward block Gauss-Seidel sweep t = (D + L)^-1 r, the backward one t = (D + U)^-1 r with
 * u = U t = r - D t on the way when u is not NULL (t may be r; u another array), and y = D x
 * (x and y do not overlap). */
void sim_hm_bsr_lower_solve(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, const float *r, float *t);
void sim_hm_bsr_upper_solve(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, const float *r, float *t,
                            float *u);
void sim_hm_bsr_diag_apply(const sim_hm_bsr *m, const uint8_t *fixed, const float *x, float *y);
/* The forward sweep of sim_hm_bsr_lower_solve on 3 vectors in place (t[v] = (D + L)^-1 t[v]) in
 * one pass over the blocks, each vector's result the same as alone. */
void sim_hm_bsr_lower_solve3(const sim_hm_bsr *m, const float *dinv, const uint8_t *fixed, float *const t[3]);

/* Solves A vn = rhs by modified CG: rows with fixed[i] keep vn_i = z_i; starts from vn = z (the
 * others: moving with the head) or from h->v plus the last solve's change h->dvp (which it then
 * sets) when that is nearer, the sliding rows' (SIM_HM_SLIDING) start keeping z along their normals (the
 * system sim_hm_filter_sliding made keeps it there); stops at cg_tolerance of the residual of vn = 0 on the free rows
 * (their right-hand side); symmetric block Gauss-Seidel preconditioning (Eisenstat's form).
 * Returns the iterations. */
int sim_hm_cg(sim_hm *h);

/* Pushes the surface vertices not yet fixed out of the colliders of step k (world); marks them
 * fixed 2, their pushes in h->push, and returns how many vertices moved. */
uint32_t sim_hm_collide(sim_hm *h, const sim_step_desc *d, int k);

/* Deformation minimization (eq. 3-4): moves the unfixed vertices of h->x to minimize the change
 * of the mesh edges from ref (the positions before collision handling), by modified CG on the
 * edges' A^T A with the same preconditioning as sim_hm_cg. */
void sim_hm_deform_min(sim_hm *h, const float *ref);

#endif
