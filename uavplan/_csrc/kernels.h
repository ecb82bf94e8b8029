/*
 * The one header of uavplan._ckernels, the compiled kernels of uavplan. One extension module,
 * built by setup.py from the C files of this directory, one file per layer:
 *
 *   args.c       the buffer protocol, and the named argument structures the Python side
 *                passes (the world, the reachability rule, the energy): their fields are
 *                read by name, in this file only
 *   geometry.c   distances to the pieces, the cell grid, segment tests, clearance queries,
 *                vertex refinement (uavplan/_geom.py, uavplan/path/post.py)
 *   reach.c      the reachability rule and its memo, the clearance table
 *                (uavplan/planners/_kernels.py)
 *   random.c     the per-individual random streams (splitmix64 + ziggurat), numpy's signs
 *   rebuild.c    initialisation, the proposal-and-repair step, the moving-average repair,
 *                feasibility (uavplan/planners/_kernels.py)
 *   energy.c     the energy fitness on the cubic spline (uavplan/path/energy.py)
 *   spsa_step.c  one fused SPSA / SSA iteration and its helper threads
 *                (uavplan/planners/sparrow.py)
 *   astar.c      the grid A* (uavplan/planners/astar.py)
 *   heightfield.c  the terrain as a height field: exact distances to the ground and the
 *                ceiling over it (uavplan/ground.py builds it, the world carries it)
 *   module.c     the method table, and the constants Python reads from the module
 *
 * A line-by-line port of the former numba kernels: same loops, same floating-point
 * expressions in the same order, compiled without contraction into fused multiply-adds and
 * without fast-math (setup.py gives each compiler its flags for that), same random streams
 * (splitmix64 + ziggurat; numpy's bit generator for the initialisation), so results are
 * bit-identical to the numba build.
 *
 * Arrays arrive through the buffer protocol (C-contiguous float64 / int64 / bool / uint64);
 * the Python modules allocate every output array and pass it in, so nothing but Python.h is
 * needed. Plain C99.
 */
#ifndef UAVPLAN_KERNELS_H
#define UAVPLAN_KERNELS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Threads for the fused SPSA step (spsa_step's ``threads``): POSIX threads and gcc's / clang's
 * __atomic builtins; elsewhere (or built with -DUAVPLAN_NO_THREADS, to try that build) the
 * step runs on the calling thread only, and says so: the module's HAVE_THREADS is 0 (uavplan
 * reports it) and the build prints a message. */
#if defined(__GNUC__) && !defined(_WIN32) && !defined(UAVPLAN_NO_THREADS)
#include <pthread.h>
#include <sched.h>
#include <time.h>
#define HAVE_THREADS 1
#define LOAD_RELAXED(p) __atomic_load_n((p), __ATOMIC_RELAXED)
#define STORE_RELAXED(p, v) __atomic_store_n((p), (v), __ATOMIC_RELAXED)
#else
#define HAVE_THREADS 0
#define LOAD_RELAXED(p) (*(p))
#define STORE_RELAXED(p, v) (*(p) = (v))
#endif

/* No contraction into fused multiply-adds (setup.py passes -ffp-contract=off to GCC and Clang,
 * /fp:precise to MSVC); MSVC before Visual Studio 2022 17.0 contracts under /fp:precise
 * unless told not to. */
#if defined(_MSC_VER) && !defined(__clang__)
#pragma fp_contract(off)
#endif

/* Every name below is private to the extension module (only PyInit__ckernels is exported). */
#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility push(hidden)
#endif

/* ------------------------------------------------------------------------------------------
 * Constants. module.c exports them as module attributes; the Python side reads them there
 * and never writes them down again.
 */

#define GOLD 0.6180339887498949 /* the golden-section search's ratio */
#define DIST_TOL_M 1e-7         /* distances are resolved to this many metres */
#define FAR 1e300

/* how a proposal draws its random term for every attempt (Proposal.draw) */
enum { DRAW_NONE = 0, DRAW_UNIFORM = 1, DRAW_SYMMETRIC = 2, DRAW_NORMAL = 3 };

/* The reachability memo: uavplan allocates 2^MEMO_BITS slots (any power of two works here);
 * a lookup probes MEMO_PROBES slots, and a full neighbourhood means no entry (the exact test
 * runs). */
#define MEMO_BITS 21
#define MEMO_PROBES 16

/* switches of the fused SPSA step (its ``flags``) */
enum {
    SPSA_START_END = 1,  /* contribution 2: producers pulled toward the start-end line */
    SPSA_LITERAL = 2,    /* eq. 11 read literally (else the deviation reading) */
    SPSA_POP_INDEX = 4,  /* eq. 4's i ranked in the whole population (else among scroungers) */
    SPSA_ESCAPE = 8,     /* contribution 3: scroungers may escape (eq. 12) */
    SPSA_OSCILLATE = 16, /* contribution 4: oscillation optimisation (eq. 13) */
};

#define SPSA_EPS 1e-50 /* ε of eq. 5, as in Xue & Shen's reference code */

/* the most threads the fused step runs on */
#define STEP_MAX_THREADS 8

/* ------------------------------------------------------------------------------------------
 * Buffers (args.c)
 */

enum { T_F64, T_I64, T_BOOL, T_U64, T_I32 };

typedef struct {
    Py_buffer view;
    int held;
} Buf;

static inline Py_ssize_t dim(const Buf *b, int i) {
    return i < b->view.ndim ? b->view.shape[i] : 1;
}
#define F64(b) ((double *)(b).view.buf)
#define I64(b) ((int64_t *)(b).view.buf)
#define U64(b) ((uint64_t *)(b).view.buf)
#define BOOL(b) ((unsigned char *)(b).view.buf)

/* Acquire ``obj`` as a C-contiguous array of type ``t`` with ``ndim`` dimensions (-1: any). */
int get_buf(PyObject *obj, Buf *b, int t, int ndim, int writable, const char *what);
void rel(Buf *b);
/* 0 when ``cond`` holds, else -1 with a ValueError of ``msg`` */
int need(int cond, const char *msg);

/* The named structures (args.c): every argument with more than a few fields arrives as a
 * Python object whose fields are read by attribute name, by the tables of args.c only. A
 * field is an array (its kind T_F64 ...) or one of these: */
enum { K_REAL = 16, K_INT, K_FLAG, K_OBJECT };

typedef struct {
    const char *name; /* the attribute */
    const char *qual; /* "structure.attribute", for messages */
    int kind;         /* T_* (an array) or K_* */
    int ndim;         /* an array's dimensions */
    int writable;     /* the kernels write the array */
} Field;

/* One field read: an array acquired, a number converted, or an object (a new reference) */
typedef struct {
    Buf buf;
    double real;
    long long integer; /* K_INT, K_FLAG */
    PyObject *obj;
} Value;

void values_release(Value *v, int n);
int args_init(void);
PyObject *args_fields(void);

/* ------------------------------------------------------------------------------------------
 * The terrain as a height field (heightfield.c; uavplan.ground.HeightField's arrays, read by
 * args.c as part of the world)
 */

typedef struct {
    const double *xy;   /* (nr, nc, 2) the lattice points' (x, y) in the field's frame */
    const double *z;    /* (nr, nc) their ground z */
    const double *slope; /* (nr - 1, nc - 1) each cell's steepest triangle (either diagonal);
                          * its highest and lowest corner are read from z */
    const double *blk;   /* (nbr, nbc, 2) the highest and lowest z of the corners of each block
                          * of FIELD_BLOCK x FIELD_BLOCK cells (surface_walk skips blocks) */
    int64_t nr, nc, nbr, nbc;
    double ox, oy, c, s; /* world frame -> field frame: X = ox + c x - s y, Y = oy + s x + c y */
    double aff[6];       /* field frame -> lattice: col = aff0 + aff1 X + aff2 Y, row = aff3 + ... */
    double slack;        /* lattice units: how far a lattice point lies from where aff puts it */
    double per_m;        /* lattice units per metre, at most (the largest singular value of aff) */
    double lift;         /* the ground's solid: below the upper surface + lift */
    double roof;         /* the ceiling's solid: above the lower surface + roof (INFINITY: none) */
    double zmax, zmin;   /* the highest and the lowest lattice point */
    int present;         /* a field of at least 2 x 2 points */
} HField;

/* the field's metadata vector (uavplan.ground.FIELD_META): its length */
#define FIELD_META 16

int field_segment_free(const HField *f, double ax, double ay, double az, double bx, double by,
                       double bz, double thr, int probe);
double field_segment_dist(const HField *f, double ax, double ay, double az, double bx, double by,
                          double bz, double cap, int *kind_out, double *where);
double field_point_dist(const HField *f, double x, double y, double z, double cap);
/* blocks of cells (field_column's bounds over wide neighbourhoods) */
#define FIELD_BLOCK 8
typedef struct {
    int64_t nbr, nbc;
    double *top;   /* (nbr, nbc, 2): the highest corner of the ground's, the ceiling's surface */
    double *slope; /* (nbr, nbc): the steepest triangle */
} FieldBlocks;
int field_blocks_init(const HField *f, FieldBlocks *fb);
void field_blocks_free(FieldBlocks *fb);
void field_column(const HField *f, const FieldBlocks *fb, double x, double y, double z0,
                  double dz, int64_t n, double *out, double exact);

/* ------------------------------------------------------------------------------------------
 * The world (uavplan._geom.KernelWorld; read by args.c)
 */

typedef struct {
    const double *poly_xy; /* (npoly, vmax, 2) */
    Py_ssize_t vmax;
    const int64_t *poly_n; /* (npoly,) */
    const double *poly_h;  /* (npoly,) */
    const double *circ;    /* (ncirc, 4) */
    const double *box;     /* (npieces, 5) */
    Py_ssize_t npoly, ncirc, npieces;
    const double *hp; /* (nhp, 3) */
    Py_ssize_t nhp;
    const double *zlim;          /* (2,) */
    const double *gmeta;         /* (6,) */
    const int64_t *cell_start;   /* (ncells + 1,) */
    const int64_t *cell_items;   /* (m,) */
    const int64_t *piece_cells;  /* (npieces, 4) */
    int grid;                    /* cell arrays present */
    HField f;                    /* the terrain (f.present == 0: none) */
} World;

/* the world's fields: 5 pieces, 2 bounds, 4 cell grid, then the 4 of the height field, which
 * world_get always reads */
#define WORLD_BUFS 16

typedef struct {
    World w;
    Value v[WORLD_BUFS];
} WorldBufs;

void world_release(WorldBufs *wb);
int world_get(PyObject *tup, WorldBufs *wb, int n_min);

/* ------------------------------------------------------------------------------------------
 * Geometry (geometry.c)
 */

static inline double dmin(double a, double b) { return b < a ? b : a; }
static inline double dmax(double a, double b) { return b > a ? b : a; }
static inline int64_t imin(int64_t a, int64_t b) { return b < a ? b : a; }
static inline int64_t imax(int64_t a, int64_t b) { return b > a ? b : a; }

/* Vertical distance from height pz to a piece spanning z in [0, h]; a negative h is a
 * ceiling piece spanning [-h, inf) (the terrain-following ceiling). */
static inline double dz_of(double pz, double h) {
    if (h < 0.0) return pz < -h ? -h - pz : 0.0;
    if (pz > h) return pz - h;
    if (pz < 0.0) return -pz;
    return 0.0;
}

double point_piece_dist(double px, double py, double pz, int64_t k, const World *w);
int segment_free(double ax, double ay, double az, double bx, double by, double bz,
                 const World *w, double margin);

/* ------------------------------------------------------------------------------------------
 * The reachability rule and its memo (reach.c; the Reach structure is read by args.c)
 */

#define EMPTY 0 /* an empty memo slot (a key is >= 2^48: its column is >= 1) */

static inline double round_grid(double v) {
    if (!(v < 1e6))
        v = 1e6;
    else if (v < -1e6)
        v = -1e6;
    /* floor(v + 0.5) without the library call (gcc inlines floor for a baseline x86-64 as
     * a long sequence): t is finite with |t| <= 1e6 + 0.5, so the truncation to int64 is
     * exact and one correction gives the floor; t is never -0.0 (v + 0.5 = -0.0 has no
     * solution), so the sign of a zero result is floor's too. */
    double t = v + 0.5;
    double i = (double)(int64_t)t;
    return i > t ? i - 1.0 : i;
}

static inline int64_t memo_key(int64_t j, double y0, double z0, double y1, double z1) {
    if (j == 1) {
        y0 = 0.0;
        z0 = 0.0;
    }
    int64_t a = (int64_t)y0 + 2048;
    int64_t b = (int64_t)z0 + 2048;
    int64_t c = (int64_t)y1 + 2048;
    int64_t d = (int64_t)z1 + 2048;
    if (j < 1 || j >= 4096 || a < 0 || a >= 4096 || b < 0 || b >= 4096) return -1;
    if (c < 0 || c >= 4096 || d < 0 || d >= 4096) return -1;
    return (((((j << 12) | a) << 12 | b) << 12 | c) << 12) | d;
}

static inline int64_t mul_wrap(int64_t a, uint64_t b) { return (int64_t)((uint64_t)a * b); }

static inline int64_t memo_slot(const int64_t *keys, int64_t nkeys, int64_t key) {
    const uint64_t mix1 = 0xBF58476D1CE4E5B9ULL; /* -4658895280553007687 as uint64 */
    const uint64_t mix2 = 0x94D049BB133111EBULL; /* -7723592293110705685 as uint64 */
    int64_t mask = nkeys - 1;
    int64_t h = key ^ (key >> 30);
    h = mul_wrap(h, mix1) ^ (mul_wrap(h, mix1) >> 27);
    h = mul_wrap(h, mix2) ^ (mul_wrap(h, mix2) >> 31);
    h &= mask;
    for (int p = 0; p < MEMO_PROBES; p++) {
        int64_t k = LOAD_RELAXED(&keys[h]);
        if (k == EMPTY || (k >> 1) == key) return h;
        h = (h + 1) & mask;
    }
    return -1;
}

typedef struct {
    const double *cols; /* (D + 1, 4) */
    int64_t ncols;      /* D + 1 */
    double dy, dz;
    double lim;
    const double *tab; /* (D + 1, ny, nz) */
    int64_t tny, tnz, tn0;
    const int64_t *off; /* (2,) */
    int64_t *keys;
    int64_t nkeys;
    const double *start_m, *goal_m;
    double margin;
    int64_t *counts;
    World w;
} Reach;

static inline double node_x(int64_t j, double y, const Reach *r) {
    return r->cols[4 * j + 0] + y * r->dy * r->cols[4 * j + 2];
}

static inline double node_y(int64_t j, double y, const Reach *r) {
    return r->cols[4 * j + 1] + y * r->dy * r->cols[4 * j + 3];
}

static inline double margin_limit(double margin) {
    double lim = margin - 1e-9;
    return lim >= 1e-9 ? lim : 1e-9;
}

static inline int node_status(int64_t j, double y0, double z0, double y1, double z1,
                              const Reach *r) {
    int64_t ny = r->tny;
    int64_t nz = r->tnz;
    int64_t c = (int64_t)y1 - r->off[0];
    int64_t d = (int64_t)z1 - r->off[1];
    if (c < 0 || c >= ny || d < 0 || d >= nz) return 0;
    double d1 = r->tab[(j * ny + c) * nz + d];
    if (d1 < r->lim) return 0;
    if (1 < j && j < r->tn0 - 2) {
        int64_t a = (int64_t)y0 - r->off[0];
        int64_t b = (int64_t)z0 - r->off[1];
        if (a < 0 || a >= ny || b < 0 || b >= nz) return 0;
        double d0 = r->tab[((j - 1) * ny + a) * nz + b];
        if (d0 < r->lim) return 0;
        const double *cj = r->cols + 4 * j;
        const double *cp = r->cols + 4 * (j - 1);
        double dy = r->dy;
        double ex = (cj[0] + y1 * dy * cj[2]) - (cp[0] + y0 * dy * cp[2]);
        double ey = (cj[1] + y1 * dy * cj[3]) - (cp[1] + y0 * dy * cp[3]);
        double ez = (z1 - z0) * r->dz;
        double length = sqrt(ex * ex + ey * ey + ez * ez);
        if (d0 + d1 - length >= 2.0 * r->lim) return 1;
    }
    int64_t key = memo_key(j, y0, z0, y1, z1);
    if (key < 0) return -1;
    int64_t slot = memo_slot(r->keys, r->nkeys, key);
    if (slot < 0) return -1;
    int64_t entry = LOAD_RELAXED(&r->keys[slot]);
    if (entry == EMPTY) return -1;
    return (int)(entry & 1);
}

int node_resolve(int64_t j, double y0, double z0, double y1, double z1, const Reach *r);

/* node_status, then node_resolve: 1 reachable or 0, plus 2 when the exact test ran */
static inline int reachable(int64_t j, double y0, double z0, double y1, double z1,
                            const Reach *r) {
    int code = node_status(j, y0, z0, y1, z1, r);
    if (code < 0) code = 2 + node_resolve(j, y0, z0, y1, z1, r);
    return code;
}

#define REACH_NFIELDS 10

typedef struct {
    WorldBufs wb;
    Value v[REACH_NFIELDS];
} ReachBufs;

int reach_get(PyObject *o, Reach *r, ReachBufs *rb);
void reach_release(ReachBufs *rb);

/* ------------------------------------------------------------------------------------------
 * Random streams (random.c)
 */

#define SM_GAMMA 0x9E3779B97F4A7C15ULL
#define SM_M1 0xBF58476D1CE4E5B9ULL
#define SM_M2 0x94D049BB133111EBULL

static inline uint64_t next_u64(uint64_t *st) {
    *st += SM_GAMMA;
    uint64_t z = *st;
    z = (z ^ (z >> 30)) * SM_M1;
    z = (z ^ (z >> 27)) * SM_M2;
    return z ^ (z >> 31);
}

static inline double rand_u(uint64_t *st) {
    return (double)(next_u64(st) >> 11) * (1.0 / 9007199254740992.0);
}

/* Marsaglia & Tsang's ziggurat (2000) for the standard normal, 128 layers */
extern double ZKN[128], ZWN[128], ZFN[128];
#define ZR 3.442619855899
void ziggurat_init(void);
double randn_tail(uint64_t *st, double hz, int iz);

static inline double randn(uint64_t *st) {
    uint64_t u = next_u64(st);
    int iz = (int)(u & 127u);
    double hz = (double)(int32_t)(uint32_t)(u >> 32);
    if (fabs(hz) < ZKN[iz]) return hz * ZWN[iz];
    return randn_tail(st, hz, iz);
}

static inline double draw_kind(int64_t kind, uint64_t *st) {
    if (kind == DRAW_UNIFORM) return rand_u(st);
    if (kind == DRAW_SYMMETRIC) return 2.0 * rand_u(st) - 1.0;
    if (kind == DRAW_NORMAL) return randn(st);
    return 0.0;
}

/* numpy's bit generator (the initialisation draws from the caller's Generator) */
typedef struct {
    void *state;
    uint64_t (*next_uint64)(void *st);
    uint32_t (*next_uint32)(void *st);
    double (*next_double)(void *st);
    uint64_t (*next_raw)(void *st);
} bitgen_t;

/* ------------------------------------------------------------------------------------------
 * Initialisation, proposal-and-repair, moving-average repair (rebuild.c). Both cores work on
 * the individuals g0 .. g1 − 1 (the fused step's threads take one at a time; everyone else
 * passes 0, n_pop).
 */

int64_t rebuild_core(const double *base, int64_t n_pop, int64_t n_inner,
                     const unsigned char *active, const double *anchor, const double *offset,
                     const double *spread, const int64_t *draw, const double *spread2,
                     const int64_t *draw2, const double *clamp, const double *first,
                     const unsigned char *use_first, const double *explicit_,
                     const int64_t *n_explicit, const unsigned char *escape, int64_t t_max,
                     int64_t v_min, int64_t v_max, const Reach *rp, const uint64_t *seeds,
                     double *out, unsigned char *ok, int64_t *n_chk_out, int64_t *n_exact_out,
                     int64_t g0, int64_t g1);
void mar_core(double *nodes, int64_t n_pop, int64_t n_inner, const double *goal_u,
              int64_t window, const Reach *rp, const unsigned char *skip, int64_t *moved,
              double *new_, int64_t *n_chk_out, int64_t *n_exact_out, int64_t g0, int64_t g1);

/* ------------------------------------------------------------------------------------------
 * Energy (energy.c; the Energy structure is read by args.c)
 */

/* What the fitness of one problem reads (see population_energy in uavplan/path/energy.py);
 * ``work`` is scratch for 2·max(inner, 1) + 8·(inner + 2) values (energy_init fills the
 * Thomas factors at its start). */
typedef struct {
    const double *start_yz, *goal_yz, *cols;
    double dx, dy, dz, k0, k1, mu0, k2;
    int64_t n_sub, smooth, inner;
    int straight;
    double *work;
    double *coef; /* per sub-step k: u, a = 1 − u, c, d (the spline's weights) */
    double *samp; /* 7 × samples: x, y, z of every sample, then each step's ex, ey, ez, length */
    const double *phys; /* the physical fitness's table (energy.c PHYS_*), NULL: the paper's */
    int64_t n_phys;
} Energy;

#define ENERGY_NFIELDS 14

typedef struct {
    Value v[ENERGY_NFIELDS];
} EnergyBufs;

int energy_init(Energy *e);
int energy_get(PyObject *o, Energy *e, EnergyBufs *eb, int64_t inner);
void energy_release(Energy *e, EnergyBufs *eb);
void energy_knots(const double *nodes, const Energy *e);
int bound_valid(const Energy *e);
double bound_from_knots(const Energy *e);
double energy_from_knots(const Energy *e);
double energy_one(const double *nodes, const Energy *e);
double energy_bound(const double *nodes, const Energy *e);
int phys_check(const double *phys, int64_t n);

/* ------------------------------------------------------------------------------------------
 * The fused SPSA step's arguments besides the population (uavplan.planners._kernels'
 * StepSetup and StepDraws; read by args.c)
 */

#define SETUP_NFIELDS 14
#define DRAWS_NFIELDS 6
#define CACHE_NFIELDS 3

typedef struct {
    Reach r;
    ReachBufs rb;
    Energy e;
    EnergyBufs eb;
    const Buf *line, *goal_u;                  /* (n, 2), (>= 2,) */
    long long n_prod, iterations, t_max, v_min, v_max, window, flags, threads;
    double warning_value;
    int has_cache;
    const Buf *filled, *values, *paths;        /* the fitness cache, when has_cache */
    double warn;                               /* the draws */
    const Buf *pdraw, *signs, *aware, *seeds1, *seeds2;
    Value setup[SETUP_NFIELDS], draws[DRAWS_NFIELDS], cache[CACHE_NFIELDS];
} StepArgs;

int step_args_get(PyObject *setup, PyObject *draws, int64_t inner, StepArgs *a);
void step_args_release(StepArgs *a);

/* ------------------------------------------------------------------------------------------
 * The functions of the module's method table (module.c)
 */

PyObject *py_astar_kernel(PyObject *self, PyObject *args);
PyObject *py_cells_count(PyObject *self, PyObject *args);
PyObject *py_cells_fill(PyObject *self, PyObject *args);
PyObject *py_clearance_table(PyObject *self, PyObject *args);
PyObject *py_energy_bounds(PyObject *self, PyObject *args);
PyObject *py_farthest_visible(PyObject *self, PyObject *args);
PyObject *py_field_heights(PyObject *self, PyObject *args);
PyObject *py_field_nearest(PyObject *self, PyObject *args);
PyObject *py_init_population(PyObject *self, PyObject *args);
PyObject *py_largest_free_fraction(PyObject *self, PyObject *args);
PyObject *py_moving_average_repair(PyObject *self, PyObject *args);
PyObject *py_node_clearance(PyObject *self, PyObject *args);
PyObject *py_node_resolve(PyObject *self, PyObject *args);
PyObject *py_node_status(PyObject *self, PyObject *args);
PyObject *py_paths_feasible(PyObject *self, PyObject *args);
PyObject *py_point_piece_dist(PyObject *self, PyObject *args);
PyObject *py_point_polygon_dist2d(PyObject *self, PyObject *args);
PyObject *py_points_clearance(PyObject *self, PyObject *args);
PyObject *py_polyline_energy(PyObject *self, PyObject *args);
PyObject *py_population_energy(PyObject *self, PyObject *args);
PyObject *py_reachable(PyObject *self, PyObject *args);
PyObject *py_rebuild(PyObject *self, PyObject *args);
PyObject *py_refine_vertices(PyObject *self, PyObject *args);
PyObject *py_round_grid(PyObject *self, PyObject *args);
PyObject *py_seg_piece_dist(PyObject *self, PyObject *args);
PyObject *py_segment_free(PyObject *self, PyObject *args);
PyObject *py_segments_clearance(PyObject *self, PyObject *args);
PyObject *py_segments_free(PyObject *self, PyObject *args);
PyObject *py_sign_draws(PyObject *self, PyObject *args);
PyObject *py_spline_points(PyObject *self, PyObject *args);
PyObject *py_spsa_step(PyObject *self, PyObject *args);
PyObject *py_stream_draws(PyObject *self, PyObject *args);
PyObject *py_ziggurat_tables(PyObject *self, PyObject *args);

#if defined(__GNUC__) && !defined(_WIN32)
#pragma GCC visibility pop
#endif

#endif /* UAVPLAN_KERNELS_H */
