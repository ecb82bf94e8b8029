/*
 * uavplan._ckernels: the compiled kernels of uavplan (world geometry, the swarm's
 * reachability rule, the energy fitness, the grid A*), built by pip at install time.
 *
 * A line-by-line port of the former numba kernels of uavplan/_geom.py,
 * uavplan/planners/_kernels.py, uavplan/path/energy.py and uavplan/planners/astar.py: same
 * loops, same floating-point expressions in the same order (compiled with
 * -ffp-contract=off, no fast-math), same random streams (splitmix64 + ziggurat; numpy's
 * bit generator for the initialisation), so results are bit-identical to the numba build.
 *
 * Arrays arrive through the buffer protocol (C-contiguous float64 / int64 / bool / uint64);
 * the Python modules allocate every output array and pass it in, so this file needs
 * nothing but Python.h.  Plain C99.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* Threads for the fused SPSA step (spsa_step's ``threads``): POSIX threads and gcc's / clang's
 * __atomic builtins; elsewhere the step runs on the calling thread only. */
#if defined(__GNUC__) && !defined(_WIN32)
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

#define GOLD 0.6180339887498949
#define DIST_TOL_M 1e-7
#define FAR 1e300

/* ------------------------------------------------------------------------------------------
 * Buffers
 */

enum { T_F64, T_I64, T_BOOL, T_U64, T_I32 };

typedef struct {
    Py_buffer view;
    int held;
} Buf;

static const char *type_name(int t) {
    switch (t) {
    case T_F64: return "float64";
    case T_I64: return "int64";
    case T_BOOL: return "bool";
    case T_I32: return "int32";
    default: return "uint64";
    }
}

static int format_ok(const Py_buffer *v, int t) {
    const char *f = v->format ? v->format : "B";
    if (*f == '<' || *f == '=' || *f == '@') f++;
    if (f[0] == 0 || f[1] != 0) return 0;
    switch (t) {
    case T_F64: return v->itemsize == 8 && f[0] == 'd';
    case T_I64: return v->itemsize == 8 && (f[0] == 'l' || f[0] == 'q');
    case T_U64: return v->itemsize == 8 && (f[0] == 'L' || f[0] == 'Q');
    case T_I32: return v->itemsize == 4 && (f[0] == 'i' || f[0] == 'l');
    default: return v->itemsize == 1 && f[0] == '?';
    }
}

/* Acquire ``obj`` as a C-contiguous array of type ``t`` with ``ndim`` dimensions (-1: any). */
static int get_buf(PyObject *obj, Buf *b, int t, int ndim, int writable, const char *what) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    b->held = 0;
    if (PyObject_GetBuffer(obj, &b->view, flags) < 0) {
        PyErr_Format(PyExc_TypeError, "%s: expected a C-contiguous%s %s array", what,
                     writable ? " writable" : "", type_name(t));
        return -1;
    }
    b->held = 1;
    if (!format_ok(&b->view, t)) {
        PyErr_Format(PyExc_TypeError, "%s: expected %s items, got format '%s'", what,
                     type_name(t), b->view.format ? b->view.format : "B");
        PyBuffer_Release(&b->view);
        b->held = 0;
        return -1;
    }
    if (ndim >= 0 && b->view.ndim != ndim) {
        PyErr_Format(PyExc_ValueError, "%s: expected %d dimensions, got %d", what, ndim,
                     b->view.ndim);
        PyBuffer_Release(&b->view);
        b->held = 0;
        return -1;
    }
    return 0;
}

static void rel(Buf *b) {
    if (b->held) {
        PyBuffer_Release(&b->view);
        b->held = 0;
    }
}

static Py_ssize_t dim(const Buf *b, int i) { return i < b->view.ndim ? b->view.shape[i] : 1; }
#define F64(b) ((double *)(b).view.buf)
#define I64(b) ((int64_t *)(b).view.buf)
#define U64(b) ((uint64_t *)(b).view.buf)
#define BOOL(b) ((unsigned char *)(b).view.buf)

static int need(int cond, const char *msg) {
    if (!cond) {
        PyErr_SetString(PyExc_ValueError, msg);
        return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * The world tuple (see uavplan.world.World.kernel_args)
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
} World;

#define WORLD_BUFS 11

typedef struct {
    World w;
    Buf b[WORLD_BUFS];
} WorldBufs;

static void world_release(WorldBufs *wb) {
    for (int i = 0; i < WORLD_BUFS; i++) rel(&wb->b[i]);
}

/* Parse a world tuple; ``n_min`` = 5 (pieces only), 7 (and bounds) or 11 (and the grid). */
static int world_get(PyObject *tup, WorldBufs *wb, int n_min) {
    static const char *names[WORLD_BUFS] = {"poly_xy", "poly_n",     "poly_h",     "circ",
                                            "box",     "hp",         "zlim",       "gmeta",
                                            "cell_start", "cell_items", "piece_cells"};
    static const int types[WORLD_BUFS] = {T_F64, T_I64, T_F64, T_F64, T_F64, T_F64,
                                          T_F64, T_F64, T_I64, T_I64, T_I64};
    static const int ndims[WORLD_BUFS] = {3, 1, 1, 2, 2, 2, 1, 1, 1, 1, 2};
    memset(wb, 0, sizeof(*wb));
    if (!PyTuple_Check(tup) || PyTuple_GET_SIZE(tup) < n_min) {
        PyErr_Format(PyExc_TypeError, "world: expected a tuple of at least %d arrays", n_min);
        return -1;
    }
    Py_ssize_t n = PyTuple_GET_SIZE(tup);
    if (n > WORLD_BUFS) n = WORLD_BUFS;
    for (int i = 0; i < n; i++) {
        if (get_buf(PyTuple_GET_ITEM(tup, i), &wb->b[i], types[i], ndims[i], 0, names[i]) < 0) {
            world_release(wb);
            return -1;
        }
    }
    World *w = &wb->w;
    w->poly_xy = F64(wb->b[0]);
    w->npoly = dim(&wb->b[0], 0);
    w->vmax = dim(&wb->b[0], 1);
    w->poly_n = I64(wb->b[1]);
    w->poly_h = F64(wb->b[2]);
    w->circ = F64(wb->b[3]);
    w->ncirc = dim(&wb->b[3], 0);
    w->box = F64(wb->b[4]);
    w->npieces = dim(&wb->b[4], 0);
    if (need(dim(&wb->b[0], 2) == 2 && dim(&wb->b[1], 0) == w->npoly &&
                 dim(&wb->b[2], 0) == w->npoly && (w->ncirc == 0 || dim(&wb->b[3], 1) == 4) &&
                 w->npieces == w->npoly + w->ncirc && dim(&wb->b[4], 1) == 5,
             "world: inconsistent piece arrays") < 0) {
        world_release(wb);
        return -1;
    }
    for (Py_ssize_t k = 0; k < w->npoly; k++) {
        if (w->poly_n[k] < 0 || w->poly_n[k] > w->vmax) {
            world_release(wb);
            return need(0, "world: polygon vertex count out of range");
        }
    }
    if (n >= 7) {
        w->hp = F64(wb->b[5]);
        w->nhp = dim(&wb->b[5], 0);
        w->zlim = F64(wb->b[6]);
        if (need((w->nhp == 0 || dim(&wb->b[5], 1) == 3) && dim(&wb->b[6], 0) == 2,
                 "world: inconsistent bounds arrays") < 0) {
            world_release(wb);
            return -1;
        }
    }
    if (n >= 11) {
        w->gmeta = F64(wb->b[7]);
        w->cell_start = I64(wb->b[8]);
        w->cell_items = I64(wb->b[9]);
        w->piece_cells = I64(wb->b[10]);
        Py_ssize_t nx = dim(&wb->b[7], 0) >= 5 ? (Py_ssize_t)w->gmeta[3] : -1;
        Py_ssize_t ny = dim(&wb->b[7], 0) >= 5 ? (Py_ssize_t)w->gmeta[4] : -1;
        if (need(nx >= 0 && ny >= 0 &&
                     (w->npieces == 0 || nx == 0 ||
                      (dim(&wb->b[8], 0) == nx * ny + 1 && dim(&wb->b[10], 0) == w->npieces &&
                       dim(&wb->b[10], 1) == 4)),
                 "world: inconsistent cell grid") < 0) {
            world_release(wb);
            return -1;
        }
        w->grid = 1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * Geometry (uavplan/_geom.py)
 */

static inline double dmin(double a, double b) { return b < a ? b : a; }
static inline double dmax(double a, double b) { return b > a ? b : a; }
static inline int64_t imin(int64_t a, int64_t b) { return b < a ? b : a; }
static inline int64_t imax(int64_t a, int64_t b) { return b > a ? b : a; }

static inline double point_seg2d_sq(double px, double py, double ax, double ay, double bx,
                                    double by) {
    double ex = bx - ax;
    double ey = by - ay;
    double den = ex * ex + ey * ey;
    double t = 0.0;
    if (den > 0.0) {
        t = ((px - ax) * ex + (py - ay) * ey) / den;
        if (t < 0.0)
            t = 0.0;
        else if (t > 1.0)
            t = 1.0;
    }
    double dx = px - (ax + t * ex);
    double dy = py - (ay + t * ey);
    return dx * dx + dy * dy;
}

static double point_polygon_dist2d(double px, double py, const double *verts, int64_t n) {
    int inside = 1;
    double best = FAR;
    for (int64_t i = 0; i < n; i++) {
        double ax = verts[2 * i];
        double ay = verts[2 * i + 1];
        int64_t j = i + 1;
        if (j == n) j = 0;
        double bx = verts[2 * j];
        double by = verts[2 * j + 1];
        if ((bx - ax) * (py - ay) - (by - ay) * (px - ax) < 0.0) inside = 0;
        double d = point_seg2d_sq(px, py, ax, ay, bx, by);
        if (d < best) best = d;
    }
    if (inside) return 0.0;
    return sqrt(best);
}

/* Vertical distance from height pz to a piece spanning z in [0, h]; a negative h is a
 * ceiling piece spanning [-h, inf) (the terrain-following ceiling). */
static inline double dz_of(double pz, double h) {
    if (h < 0.0) return pz < -h ? -h - pz : 0.0;
    if (pz > h) return pz - h;
    if (pz < 0.0) return -pz;
    return 0.0;
}

static double py_hypot(double x, double y) {
    /* numba's math.hypot: inf if either is infinite, else the C library's hypot */
    if (isinf(x) || isinf(y)) return INFINITY;
    return hypot(x, y);
}

static double point_piece_dist(double px, double py, double pz, int64_t k, const World *w) {
    double dh, dz;
    if (k < w->npoly) {
        dh = point_polygon_dist2d(px, py, w->poly_xy + k * w->vmax * 2, w->poly_n[k]);
        dz = dz_of(pz, w->poly_h[k]);
    } else {
        const double *c = w->circ + (k - w->npoly) * 4;
        dh = py_hypot(px - c[0], py - c[1]) - c[2];
        if (dh < 0.0) dh = 0.0;
        dz = dz_of(pz, c[3]);
    }
    return sqrt(dh * dh + dz * dz);
}

static double seg_piece_dist(double ax, double ay, double az, double bx, double by, double bz,
                             int64_t k, const World *w, double thr) {
    const double *bk = w->box + 5 * k;
    if (thr >= 0.0) {
        if (dmax(ax, bx) < bk[0] - thr || dmin(ax, bx) > bk[1] + thr) return FAR;
        if (dmax(ay, by) < bk[2] - thr || dmin(ay, by) > bk[3] + thr) return FAR;
        if (dmin(az, bz) > bk[4] + thr) return FAR;
        if (k < w->npoly && w->poly_h[k] < 0.0 && dmax(az, bz) < -w->poly_h[k] - thr)
            return FAR; /* wholly below a ceiling piece */
    }
    double dx = bx - ax;
    double dy = by - ay;
    double dz = bz - az;
    double length = sqrt(dx * dx + dy * dy + dz * dz);
    double fa = point_piece_dist(ax, ay, az, k, w);
    if (fa < thr) return fa;
    double fb = point_piece_dist(bx, by, bz, k, w);
    double best = dmin(fa, fb);
    if (fb < thr || length <= 0.0) return best;
    if (thr >= 0.0 && 0.5 * (fa + fb - length) >= thr) return 0.5 * (fa + fb - length);
    double lo = 0.0;
    double hi = 1.0;
    double x1 = hi - GOLD;
    double x2 = GOLD;
    double f1 = point_piece_dist(ax + x1 * dx, ay + x1 * dy, az + x1 * dz, k, w);
    double f2 = point_piece_dist(ax + x2 * dx, ay + x2 * dy, az + x2 * dz, k, w);
    for (int it = 0; it < 200; it++) {
        double fm = dmin(f1, f2);
        if (fm < best) best = fm;
        if (best < thr) return best;
        double width = (hi - lo) * length;
        if (thr >= 0.0 && fm - width >= thr) return fm - width;
        if (width < DIST_TOL_M) break;
        if (f1 < f2) {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - GOLD * (hi - lo);
            f1 = point_piece_dist(ax + x1 * dx, ay + x1 * dy, az + x1 * dz, k, w);
        } else {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + GOLD * (hi - lo);
            f2 = point_piece_dist(ax + x2 * dx, ay + x2 * dy, az + x2 * dz, k, w);
        }
    }
    return best;
}

static inline int inside_bounds(double px, double py, double pz, const World *w) {
    double eps = 1e-9;
    if (pz < w->zlim[0] - eps || pz > w->zlim[1] + eps) return 0;
    for (Py_ssize_t i = 0; i < w->nhp; i++) {
        const double *h = w->hp + 3 * i;
        if (h[0] * px + h[1] * py > h[2] + eps) return 0;
    }
    return 1;
}

static inline void cell_range(double lo, double hi, double origin, double cell, int64_t n,
                              int64_t *a_out, int64_t *b_out) {
    int64_t a = (int64_t)floor((lo - origin) / cell);
    int64_t b = (int64_t)floor((hi - origin) / cell);
    if (a < 0) a = 0;
    if (b > n - 1) b = n - 1;
    *a_out = a;
    *b_out = b;
}

/* Whether the segment a→b keeps ``margin`` from every piece and stays inside the bounds.
 * ``hint`` (may be NULL): a piece to test first, and where the blocking piece is left when
 * the segment is not free (consecutive queries along a polyline are often blocked by the same
 * piece). The pieces tested are always the same set, so the answer does not depend on it. */
static int segment_free_h(double ax, double ay, double az, double bx, double by, double bz,
                          const World *w, double margin, int64_t *hint) {
    if (!(inside_bounds(ax, ay, az, w) && inside_bounds(bx, by, bz, w))) return 0;
    double thr = margin - 1e-9;
    if (thr < 1e-9) thr = 1e-9;
    Py_ssize_t npieces = w->npieces;
    double gx0 = w->gmeta[0];
    double gy0 = w->gmeta[1];
    double cell = w->gmeta[2];
    int64_t nx = (int64_t)w->gmeta[3];
    int64_t ny = (int64_t)w->gmeta[4];
    if (npieces == 0) return 1;
    int64_t cx0 = 0, cx1 = -1, cy0 = 0, cy1 = -1;
    if (nx != 0) {
        cell_range(dmin(ax, bx) - margin, dmax(ax, bx) + margin, gx0, cell, nx, &cx0, &cx1);
        cell_range(dmin(ay, by) - margin, dmax(ay, by) + margin, gy0, cell, ny, &cy0, &cy1);
    }
    /* the pieces tested: with a grid, those whose cells meet the segment's */
#define SF_TESTED(k)                                                                          \
    (nx == 0 || (w->piece_cells[4 * (k)] <= w->piece_cells[4 * (k) + 1] &&                      \
                 w->piece_cells[4 * (k) + 2] <= w->piece_cells[4 * (k) + 3] &&                  \
                 w->piece_cells[4 * (k) + 1] >= cx0 && w->piece_cells[4 * (k)] <= cx1 &&        \
                 w->piece_cells[4 * (k) + 3] >= cy0 && w->piece_cells[4 * (k) + 2] <= cy1))
    int64_t first = -1;
    if (hint != NULL && *hint >= 0 && *hint < (int64_t)npieces && SF_TESTED(*hint)) {
        first = *hint;
        if (seg_piece_dist(ax, ay, az, bx, by, bz, first, w, thr) < thr) return 0;
    }
    /* No grid, or a segment whose box spans more cells than there are pieces (a long leg):
     * walk the pieces in index order instead of the cells, testing the same pieces; "free"
     * does not depend on the order of the tests. */
    if (nx == 0 || (cx1 - cx0 + 1) * (cy1 - cy0 + 1) > (int64_t)npieces) {
        for (int64_t k = 0; k < npieces; k++) {
            if (k == first || !SF_TESTED(k)) continue;
            if (seg_piece_dist(ax, ay, az, bx, by, bz, k, w, thr) < thr) {
                if (hint != NULL) *hint = k;
                return 0;
            }
        }
        return 1;
    }
#undef SF_TESTED
    for (int64_t cx = cx0; cx <= cx1; cx++) {
        for (int64_t cy = cy0; cy <= cy1; cy++) {
            int64_t c = cx * ny + cy;
            for (int64_t t = w->cell_start[c]; t < w->cell_start[c + 1]; t++) {
                int64_t k = w->cell_items[t];
                const int64_t *pc = w->piece_cells + 4 * k;
                if (cx != imax(cx0, pc[0]) || cy != imax(cy0, pc[2]) || k == first) continue;
                if (seg_piece_dist(ax, ay, az, bx, by, bz, k, w, thr) < thr) {
                    if (hint != NULL) *hint = k;
                    return 0;
                }
            }
        }
    }
    return 1;
}

static int segment_free(double ax, double ay, double az, double bx, double by, double bz,
                        const World *w, double margin) {
    return segment_free_h(ax, ay, az, bx, by, bz, w, margin, NULL);
}

static inline double box_gap(double x0, double x1, double y0, double y1, double z0, double z1,
                             int64_t k, const World *w) {
    const double *bk = w->box + 5 * k;
    double gx = dmax(dmax(0.0, bk[0] - x1), x0 - bk[1]);
    double gy = dmax(dmax(0.0, bk[2] - y1), y0 - bk[3]);
    double gz = dmax(dmax(0.0, z0 - bk[4]), -z1);
    if (k < w->npoly && w->poly_h[k] < 0.0) gz = dmax(gz, -w->poly_h[k] - z1);
    return sqrt(gx * gx + gy * gy + gz * gz);
}

/* --- Python wrappers (geometry) --- */

static int get_pieces(PyObject *poly_xy, PyObject *poly_n, PyObject *poly_h, PyObject *circ,
                      WorldBufs *wb) {
    /* the four piece arrays without the boxes: npieces from their sizes */
    static const char *names[4] = {"poly_xy", "poly_n", "poly_h", "circ"};
    static const int types[4] = {T_F64, T_I64, T_F64, T_F64};
    static const int ndims[4] = {3, 1, 1, 2};
    PyObject *objs[4] = {poly_xy, poly_n, poly_h, circ};
    memset(wb, 0, sizeof(*wb));
    for (int i = 0; i < 4; i++) {
        if (get_buf(objs[i], &wb->b[i], types[i], ndims[i], 0, names[i]) < 0) {
            world_release(wb);
            return -1;
        }
    }
    World *w = &wb->w;
    w->poly_xy = F64(wb->b[0]);
    w->npoly = dim(&wb->b[0], 0);
    w->vmax = dim(&wb->b[0], 1);
    w->poly_n = I64(wb->b[1]);
    w->poly_h = F64(wb->b[2]);
    w->circ = F64(wb->b[3]);
    w->ncirc = dim(&wb->b[3], 0);
    w->npieces = w->npoly + w->ncirc;
    if (need(dim(&wb->b[0], 2) == 2 && dim(&wb->b[1], 0) == w->npoly &&
                 dim(&wb->b[2], 0) == w->npoly && (w->ncirc == 0 || dim(&wb->b[3], 1) == 4),
             "inconsistent piece arrays") < 0) {
        world_release(wb);
        return -1;
    }
    for (Py_ssize_t k = 0; k < w->npoly; k++) {
        if (w->poly_n[k] < 0 || w->poly_n[k] > w->vmax) {
            world_release(wb);
            return need(0, "polygon vertex count out of range");
        }
    }
    return 0;
}

static int check_piece(int64_t k, const World *w) {
    if (k < 0 || k >= w->npieces) {
        PyErr_SetString(PyExc_IndexError, "piece index out of range");
        return -1;
    }
    return 0;
}

static PyObject *py_point_polygon_dist2d(PyObject *self, PyObject *args) {
    double px, py;
    PyObject *o;
    long long n;
    Buf b;
    if (!PyArg_ParseTuple(args, "ddOL", &px, &py, &o, &n)) return NULL;
    if (get_buf(o, &b, T_F64, 2, 0, "verts") < 0) return NULL;
    if (n < 0 || n > dim(&b, 0) || dim(&b, 1) != 2) {
        rel(&b);
        PyErr_SetString(PyExc_ValueError, "verts: need (>= n, 2)");
        return NULL;
    }
    double d = point_polygon_dist2d(px, py, F64(b), n);
    rel(&b);
    return PyFloat_FromDouble(d);
}

static PyObject *py_point_piece_dist(PyObject *self, PyObject *args) {
    double px, py, pz;
    long long k;
    PyObject *a, *b, *c, *d;
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "dddLOOOO", &px, &py, &pz, &k, &a, &b, &c, &d)) return NULL;
    if (get_pieces(a, b, c, d, &wb) < 0) return NULL;
    if (check_piece(k, &wb.w) < 0) {
        world_release(&wb);
        return NULL;
    }
    double r = point_piece_dist(px, py, pz, k, &wb.w);
    world_release(&wb);
    return PyFloat_FromDouble(r);
}

static PyObject *py_seg_piece_dist(PyObject *self, PyObject *args) {
    double ax, ay, az, bx, by, bz, thr;
    long long k;
    PyObject *a, *b, *c, *d, *box;
    WorldBufs wb;
    Buf bb;
    if (!PyArg_ParseTuple(args, "ddddddLOOOOOd", &ax, &ay, &az, &bx, &by, &bz, &k, &a, &b, &c,
                          &d, &box, &thr))
        return NULL;
    if (get_pieces(a, b, c, d, &wb) < 0) return NULL;
    if (get_buf(box, &bb, T_F64, 2, 0, "box") < 0) {
        world_release(&wb);
        return NULL;
    }
    if (check_piece(k, &wb.w) < 0 || need(dim(&bb, 0) == wb.w.npieces && dim(&bb, 1) == 5,
                                          "box: need (pieces, 5)") < 0) {
        rel(&bb);
        world_release(&wb);
        return NULL;
    }
    wb.w.box = F64(bb);
    double r = seg_piece_dist(ax, ay, az, bx, by, bz, k, &wb.w, thr);
    rel(&bb);
    world_release(&wb);
    return PyFloat_FromDouble(r);
}

static PyObject *py_segment_free(PyObject *self, PyObject *args) {
    double ax, ay, az, bx, by, bz, margin;
    PyObject *wt;
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "ddddddOd", &ax, &ay, &az, &bx, &by, &bz, &wt, &margin))
        return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    int r = segment_free(ax, ay, az, bx, by, bz, &wb.w, margin);
    world_release(&wb);
    return PyBool_FromLong(r);
}

/* segments_free(p0, p1, W, margin, out) */
static PyObject *py_segments_free(PyObject *self, PyObject *args) {
    PyObject *o0, *o1, *wt, *oo;
    double margin;
    Buf b0 = {0}, b1 = {0}, bo = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOdO", &o0, &o1, &wt, &margin, &oo)) return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(o0, &b0, T_F64, 2, 0, "p0") < 0 || get_buf(o1, &b1, T_F64, 2, 0, "p1") < 0 ||
        get_buf(oo, &bo, T_BOOL, 1, 1, "out") < 0)
        goto done;
    Py_ssize_t n = dim(&b0, 0);
    if (need(dim(&b0, 1) == 3 && dim(&b1, 1) == 3 && dim(&b1, 0) == n && dim(&bo, 0) == n,
             "segments_free: p0, p1 (n, 3), out (n,)") < 0)
        goto done;
    const double *p0 = F64(b0), *p1 = F64(b1);
    unsigned char *out = BOOL(bo);
    for (Py_ssize_t i = 0; i < n; i++)
        out[i] = (unsigned char)segment_free(p0[3 * i], p0[3 * i + 1], p0[3 * i + 2], p1[3 * i],
                                             p1[3 * i + 1], p1[3 * i + 2], &wb.w, margin);
    ret = Py_NewRef(Py_None);
done:
    rel(&b0);
    rel(&b1);
    rel(&bo);
    world_release(&wb);
    return ret;
}

/* farthest_visible(p, W, margin, keep) -> count: the greedy farthest-reachable chain of the
 * polyline p (n, 3) (node simplification, Figure 4): from node i jump to the last j > i whose
 * segment i→j is free (i + 1 when none is); keep (n,) int64 gets the indices, 0 first and
 * n − 1 last. Scanning j downward stops at the first free segment: the same j as testing
 * every later node and taking the largest free one. */
static PyObject *py_farthest_visible(PyObject *self, PyObject *args) {
    PyObject *op, *wt, *ok;
    double margin;
    Buf bp = {0}, bk = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOdO", &op, &wt, &margin, &ok)) return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(op, &bp, T_F64, 2, 0, "p") < 0 || get_buf(ok, &bk, T_I64, 1, 1, "keep") < 0)
        goto done;
    Py_ssize_t n = dim(&bp, 0);
    if (need(n >= 1 && dim(&bp, 1) == 3 && dim(&bk, 0) >= n,
             "farthest_visible: p (n, 3), keep (n,)") < 0)
        goto done;
    const double *p = F64(bp);
    int64_t *keep = I64(bk);
    Py_ssize_t count = 0, i = 0;
    keep[count++] = 0;
    int64_t blocker = -1;
    while (i < n - 1) {
        Py_ssize_t next = i + 1;
        for (Py_ssize_t j = n - 1; j > i; j--) {
            const double *a = p + 3 * i, *b = p + 3 * j;
            if (segment_free_h(a[0], a[1], a[2], b[0], b[1], b[2], &wb.w, margin, &blocker)) {
                next = j;
                break;
            }
        }
        i = next;
        keep[count++] = i;
    }
    ret = PyLong_FromSsize_t(count);
done:
    rel(&bp);
    rel(&bk);
    world_release(&wb);
    return ret;
}

/* Energy (eq. 1-2) of the polyline p (k, 3), k >= 3, as uavplan.path.post's numpy window
 * energy computes it: lengths sqrt((x² + y²) + z²), every sum left to right, turn
 * 1 − dot/max(l_i·l_{i+1}, 1e-12), then k0·L + (k1·mu0)·T + k2·C. */
/* Whether a→(p + f·step)→b keeps the margin (both legs), the bend point computed as numpy
 * computes ``p + f * step``. */
static int bent_free(const double *p, const double *step, const double *a, const double *b,
                     double f, const World *w, double margin) {
    double c[3];
    for (int i = 0; i < 3; i++) c[i] = p[i] + f * step[i];
    return segment_free(a[0], a[1], a[2], c[0], c[1], c[2], w, margin) &&
           segment_free(c[0], c[1], c[2], b[0], b[1], b[2], w, margin);
}

/* largest_free_fraction(p, step, a, b, world, margin, bisections): the largest f in [0, 1]
 * with a→p+f·step→b free: 1 if it is, else ``bisections`` halvings of [0, 1] keeping the
 * free end (uavplan.path.post.tighten). */
static PyObject *py_largest_free_fraction(PyObject *self, PyObject *args) {
    PyObject *o[4], *wt;
    double margin;
    long long bisections;
    Buf b[4];
    WorldBufs wb;
    memset(b, 0, sizeof(b));
    if (!PyArg_ParseTuple(args, "OOOOOdL", &o[0], &o[1], &o[2], &o[3], &wt, &margin, &bisections))
        return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    static const char *names[4] = {"p", "step", "a", "b"};
    for (int i = 0; i < 4; i++) {
        if (get_buf(o[i], &b[i], T_F64, 1, 0, names[i]) < 0) goto done;
        if (need(dim(&b[i], 0) == 3, "largest_free_fraction: p, step, a, b are 3-vectors") < 0)
            goto done;
    }
    const double *p = F64(b[0]), *step = F64(b[1]), *a = F64(b[2]), *bb = F64(b[3]);
    double lo = 0.0;
    if (bent_free(p, step, a, bb, 1.0, &wb.w, margin)) {
        lo = 1.0;
    } else {
        double hi = 1.0;
        for (long long k = 0; k < bisections; k++) {
            double mid = 0.5 * (lo + hi);
            if (bent_free(p, step, a, bb, mid, &wb.w, margin))
                lo = mid;
            else
                hi = mid;
        }
    }
    ret = PyFloat_FromDouble(lo);
done:
    for (int i = 0; i < 4; i++) rel(&b[i]);
    world_release(&wb);
    return ret;
}

static double window_energy(const double *p, int64_t k, double k0, double k1mu0, double k2) {
    double d[4 * 3], len[4];
    for (int64_t i = 0; i < k - 1; i++) {
        double dx = p[3 * (i + 1)] - p[3 * i];
        double dy = p[3 * (i + 1) + 1] - p[3 * i + 1];
        double dz = p[3 * (i + 1) + 2] - p[3 * i + 2];
        d[3 * i] = dx;
        d[3 * i + 1] = dy;
        d[3 * i + 2] = dz;
        len[i] = sqrt(dx * dx + dy * dy + dz * dz);
    }
    double length = len[0], climb = fabs(d[2]), turn = 0.0;
    for (int64_t i = 1; i < k - 1; i++) {
        length += len[i];
        climb += fabs(d[3 * i + 2]);
    }
    for (int64_t i = 0; i < k - 2; i++) {
        const double *a = d + 3 * i, *b = d + 3 * (i + 1);
        double dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
        double den = len[i] * len[i + 1];
        if (den < 1e-12) den = 1e-12;
        double t = 1.0 - dot / den;
        turn = i == 0 ? t : turn + t;
    }
    return k0 * length + k1mu0 * turn + k2 * climb;
}

/* refine_vertices(v, moves, steps, passes, W, margin, (k0, k1mu0, k2)) -> None: the pattern
 * search of uavplan.path.post.refine, in place on v (n, 3). For each step size, up to
 * ``passes`` sweeps (stopping after one that moved nothing); in a sweep every interior vertex
 * k in turn moves to the neighbour v[k] + step·move (moves (m, 3)) of largest energy gain
 * (> 1e-9) over the window v[k-2 .. k+2] whose two legs are free; equal gains: the first move
 * in ``moves``. */
static PyObject *py_refine_vertices(PyObject *self, PyObject *args) {
    PyObject *ov, *om, *os, *wt;
    long long passes;
    double margin, k0, k1mu0, k2;
    Buf bv = {0}, bm = {0}, bs = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOLOd(ddd)", &ov, &om, &os, &passes, &wt, &margin, &k0, &k1mu0,
                          &k2))
        return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    double *gain = NULL;
    int64_t *order = NULL;
    if (get_buf(ov, &bv, T_F64, 2, 1, "v") < 0 || get_buf(om, &bm, T_F64, 2, 0, "moves") < 0 ||
        get_buf(os, &bs, T_F64, 1, 0, "steps") < 0)
        goto done;
    int64_t n = dim(&bv, 0), nm = dim(&bm, 0), ns = dim(&bs, 0);
    if (need(dim(&bv, 1) == 3 && dim(&bm, 1) == 3 && nm >= 1 && passes >= 0,
             "refine_vertices: v (n, 3), moves (m, 3)") < 0)
        goto done;
    gain = malloc(sizeof(double) * (size_t)nm);
    order = malloc(sizeof(int64_t) * (size_t)nm);
    if (gain == NULL || order == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *v = F64(bv);
    const double *mv = F64(bm), *steps = F64(bs);
    for (int64_t si = 0; si < ns; si++) {
        double step = steps[si];
        for (long long pass = 0; pass < passes; pass++) {
            int improved = 0;
            for (int64_t k = 1; k < n - 1; k++) {
                int64_t lo = k - 2 > 0 ? k - 2 : 0, hi = k + 3 < n ? k + 3 : n;
                int64_t ws = hi - lo, at = k - lo;
                double win[5 * 3], trial[5 * 3], cand[3];
                memcpy(win, v + 3 * lo, sizeof(double) * 3 * (size_t)ws);
                memcpy(trial, win, sizeof(double) * 3 * (size_t)ws);
                double e0 = window_energy(win, ws, k0, k1mu0, k2);
                int64_t nb = 0;
                for (int64_t q = 0; q < nm; q++) {
                    for (int a = 0; a < 3; a++) trial[3 * at + a] = v[3 * k + a] + step * mv[3 * q + a];
                    gain[q] = e0 - window_energy(trial, ws, k0, k1mu0, k2);
                    if (gain[q] > 1e-9) {
                        /* insertion by descending gain; equal gains keep the move order */
                        int64_t i = nb++;
                        while (i > 0 && gain[order[i - 1]] < gain[q]) {
                            order[i] = order[i - 1];
                            i--;
                        }
                        order[i] = q;
                    }
                }
                const double *a = v + 3 * (k - 1), *b = v + 3 * (k + 1);
                for (int64_t i = 0; i < nb; i++) {
                    int64_t q = order[i];
                    for (int c = 0; c < 3; c++) cand[c] = v[3 * k + c] + step * mv[3 * q + c];
                    if (segment_free(a[0], a[1], a[2], cand[0], cand[1], cand[2], &wb.w, margin) &&
                        segment_free(cand[0], cand[1], cand[2], b[0], b[1], b[2], &wb.w, margin)) {
                        memcpy(v + 3 * k, cand, sizeof(cand));
                        improved = 1;
                        break;
                    }
                }
            }
            if (!improved) break;
        }
    }
    ret = Py_NewRef(Py_None);
done:
    free(gain);
    free(order);
    rel(&bv);
    rel(&bm);
    rel(&bs);
    world_release(&wb);
    return ret;
}

/* points_clearance(p, W, dist, which): dist pre-filled with inf, which with -1 */
static PyObject *py_points_clearance(PyObject *self, PyObject *args) {
    PyObject *op, *wt, *od, *ow;
    Buf bp = {0}, bd = {0}, bw = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOO", &op, &wt, &od, &ow)) return NULL;
    if (world_get(wt, &wb, 5) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(op, &bp, T_F64, 2, 0, "p") < 0 || get_buf(od, &bd, T_F64, 1, 1, "dist") < 0 ||
        get_buf(ow, &bw, T_I64, 1, 1, "which") < 0)
        goto done;
    Py_ssize_t n = dim(&bp, 0);
    if (need(dim(&bp, 1) == 3 && dim(&bd, 0) == n && dim(&bw, 0) == n,
             "points_clearance: p (n, 3), dist (n,), which (n,)") < 0)
        goto done;
    const double *p = F64(bp);
    double *dist = F64(bd);
    int64_t *which = I64(bw);
    const World *w = &wb.w;
    for (Py_ssize_t i = 0; i < n; i++) {
        const double *q = p + 3 * i;
        for (int64_t k = 0; k < w->npieces; k++) {
            if (box_gap(q[0], q[0], q[1], q[1], q[2], q[2], k, w) >= dist[i]) continue;
            double d = point_piece_dist(q[0], q[1], q[2], k, w);
            if (d < dist[i]) {
                dist[i] = d;
                which[i] = k;
            }
        }
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&bp);
    rel(&bd);
    rel(&bw);
    world_release(&wb);
    return ret;
}

static PyObject *py_segments_clearance(PyObject *self, PyObject *args) {
    PyObject *o0, *o1, *wt, *od, *ow;
    Buf b0 = {0}, b1 = {0}, bd = {0}, bw = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOOO", &o0, &o1, &wt, &od, &ow)) return NULL;
    if (world_get(wt, &wb, 5) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(o0, &b0, T_F64, 2, 0, "p0") < 0 || get_buf(o1, &b1, T_F64, 2, 0, "p1") < 0 ||
        get_buf(od, &bd, T_F64, 1, 1, "dist") < 0 || get_buf(ow, &bw, T_I64, 1, 1, "which") < 0)
        goto done;
    Py_ssize_t n = dim(&b0, 0);
    if (need(dim(&b0, 1) == 3 && dim(&b1, 1) == 3 && dim(&b1, 0) == n && dim(&bd, 0) == n &&
                 dim(&bw, 0) == n,
             "segments_clearance: p0, p1 (n, 3), dist, which (n,)") < 0)
        goto done;
    const double *p0 = F64(b0), *p1 = F64(b1);
    double *dist = F64(bd);
    int64_t *which = I64(bw);
    const World *w = &wb.w;
    for (Py_ssize_t i = 0; i < n; i++) {
        double ax = p0[3 * i], ay = p0[3 * i + 1], az = p0[3 * i + 2];
        double bx = p1[3 * i], by = p1[3 * i + 1], bz = p1[3 * i + 2];
        double x0 = dmin(ax, bx), x1 = dmax(ax, bx);
        double y0 = dmin(ay, by), y1 = dmax(ay, by);
        double z0 = dmin(az, bz), z1 = dmax(az, bz);
        for (int64_t k = 0; k < w->npieces; k++) {
            if (box_gap(x0, x1, y0, y1, z0, z1, k, w) >= dist[i]) continue;
            double d = seg_piece_dist(ax, ay, az, bx, by, bz, k, w, -1.0);
            if (d < dist[i]) {
                dist[i] = d;
                which[i] = k;
            }
        }
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&b0);
    rel(&b1);
    rel(&bd);
    rel(&bw);
    world_release(&wb);
    return ret;
}

/* cells_count(box, pad, x0, y0, cell, nx, ny, piece_cells, counts) */
static PyObject *py_cells_count(PyObject *self, PyObject *args) {
    PyObject *ob, *opc, *oc;
    double pad, x0, y0, cell;
    long long nx, ny;
    Buf bb = {0}, bpc = {0}, bc = {0};
    if (!PyArg_ParseTuple(args, "OddddLLOO", &ob, &pad, &x0, &y0, &cell, &nx, &ny, &opc, &oc))
        return NULL;
    PyObject *ret = NULL;
    if (get_buf(ob, &bb, T_F64, 2, 0, "box") < 0 ||
        get_buf(opc, &bpc, T_I64, 2, 1, "piece_cells") < 0 ||
        get_buf(oc, &bc, T_I64, 1, 1, "counts") < 0)
        goto done;
    Py_ssize_t np_ = dim(&bb, 0);
    if (need(dim(&bb, 1) == 5 && dim(&bpc, 0) == np_ && dim(&bpc, 1) == 4 && nx >= 1 &&
                 ny >= 1 && dim(&bc, 0) == nx * ny + 1,
             "cells_count: inconsistent shapes") < 0)
        goto done;
    const double *box = F64(bb);
    int64_t *pc = I64(bpc), *counts = I64(bc);
    for (Py_ssize_t k = 0; k < np_; k++) {
        int64_t a0, a1, b0, b1;
        cell_range(box[5 * k + 0] - pad, box[5 * k + 1] + pad, x0, cell, nx, &a0, &a1);
        cell_range(box[5 * k + 2] - pad, box[5 * k + 3] + pad, y0, cell, ny, &b0, &b1);
        pc[4 * k + 0] = a0;
        pc[4 * k + 1] = a1;
        pc[4 * k + 2] = b0;
        pc[4 * k + 3] = b1;
        for (int64_t cx = a0; cx <= a1; cx++)
            for (int64_t cy = b0; cy <= b1; cy++) counts[cx * ny + cy + 1] += 1;
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&bb);
    rel(&bpc);
    rel(&bc);
    return ret;
}

/* cells_fill(piece_cells, ny, cell_start, cell_items) */
static PyObject *py_cells_fill(PyObject *self, PyObject *args) {
    PyObject *opc, *os, *oi;
    long long ny;
    Buf bpc = {0}, bs = {0}, bi = {0};
    if (!PyArg_ParseTuple(args, "OLOO", &opc, &ny, &os, &oi)) return NULL;
    PyObject *ret = NULL;
    int64_t *fill = NULL;
    if (get_buf(opc, &bpc, T_I64, 2, 0, "piece_cells") < 0 ||
        get_buf(os, &bs, T_I64, 1, 0, "cell_start") < 0 ||
        get_buf(oi, &bi, T_I64, 1, 1, "cell_items") < 0)
        goto done;
    Py_ssize_t ncell = dim(&bs, 0) - 1;
    const int64_t *pc = I64(bpc), *start = I64(bs);
    int64_t *items = I64(bi);
    if (need(ncell >= 0 && dim(&bpc, 1) == 4 && start[ncell] == dim(&bi, 0),
             "cells_fill: inconsistent shapes") < 0)
        goto done;
    fill = malloc(sizeof(int64_t) * (ncell > 0 ? ncell : 1));
    if (fill == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    memcpy(fill, start, sizeof(int64_t) * ncell);
    for (Py_ssize_t k = 0; k < dim(&bpc, 0); k++) {
        for (int64_t cx = pc[4 * k]; cx <= pc[4 * k + 1]; cx++) {
            for (int64_t cy = pc[4 * k + 2]; cy <= pc[4 * k + 3]; cy++) {
                int64_t c = cx * ny + cy;
                items[fill[c]] = k;
                fill[c] += 1;
            }
        }
    }
    ret = Py_NewRef(Py_None);
done:
    free(fill);
    rel(&bpc);
    rel(&bs);
    rel(&bi);
    return ret;
}

/* ------------------------------------------------------------------------------------------
 * Reachability rule (uavplan/planners/_kernels.py)
 */

#define MEMO_PROBES 16
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

/* round_grid(values, out): round_grid of every value (the tests hold it to _kernels._round) */
static PyObject *py_round_grid(PyObject *self, PyObject *args) {
    PyObject *ov, *oo;
    Buf bv = {0}, bo = {0};
    if (!PyArg_ParseTuple(args, "OO", &ov, &oo)) return NULL;
    PyObject *ret = NULL;
    if (get_buf(ov, &bv, T_F64, 1, 0, "values") < 0 || get_buf(oo, &bo, T_F64, 1, 1, "out") < 0)
        goto done;
    if (need(dim(&bv, 0) == dim(&bo, 0), "round_grid: values and out differ in length") < 0)
        goto done;
    for (Py_ssize_t i = 0; i < dim(&bv, 0); i++) F64(bo)[i] = round_grid(F64(bv)[i]);
    ret = Py_NewRef(Py_None);
done:
    rel(&bv);
    rel(&bo);
    return ret;
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

static int segment_to_node_free(int64_t j, double y0, double z0, double y1, double z1,
                                const Reach *r) {
    double ax, ay, az;
    if (j == 1) {
        ax = r->start_m[0];
        ay = r->start_m[1];
        az = r->start_m[2];
    } else {
        ax = node_x(j - 1, y0, r);
        ay = node_y(j - 1, y0, r);
        az = z0 * r->dz;
    }
    double bx = node_x(j, y1, r);
    double by = node_y(j, y1, r);
    double bz = z1 * r->dz;
    if (!segment_free(ax, ay, az, bx, by, bz, &r->w, r->margin)) return 0;
    if (j == r->ncols - 2)
        return segment_free(bx, by, bz, r->goal_m[0], r->goal_m[1], r->goal_m[2], &r->w,
                            r->margin);
    return 1;
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

static int node_resolve(int64_t j, double y0, double z0, double y1, double z1, const Reach *r) {
    int free_ = segment_to_node_free(j, y0, z0, y1, z1, r);
    int64_t key = memo_key(j, y0, z0, y1, z1);
    if (key >= 0) {
        int64_t slot = memo_slot(r->keys, r->nkeys, key);
        if (slot >= 0) STORE_RELAXED(&r->keys[slot], 2 * key + (free_ ? 1 : 0));
    }
    return free_ ? 1 : 0;
}

/* node_status, then node_resolve: 1 reachable or 0, plus 2 when the exact test ran */
static inline int reachable(int64_t j, double y0, double z0, double y1, double z1,
                            const Reach *r) {
    int code = node_status(j, y0, z0, y1, z1, r);
    if (code < 0) code = 2 + node_resolve(j, y0, z0, y1, z1, r);
    return code;
}

typedef struct {
    WorldBufs wb;
    Buf cols, memo, table, off, steps, start, goal, counts;
} ReachBufs;

static void reach_release(ReachBufs *rb) {
    world_release(&rb->wb);
    rel(&rb->cols);
    rel(&rb->memo);
    rel(&rb->table);
    rel(&rb->off);
    rel(&rb->steps);
    rel(&rb->start);
    rel(&rb->goal);
    rel(&rb->counts);
}

/* A Reach named tuple: (world, cols, memo, table, table_off, steps, start_m, goal_m, margin,
 * counts) */
static int reach_get(PyObject *o, Reach *r, ReachBufs *rb) {
    memset(rb, 0, sizeof(*rb));
    memset(r, 0, sizeof(*r));
    if (!PyTuple_Check(o) || PyTuple_GET_SIZE(o) != 10) {
        PyErr_SetString(PyExc_TypeError, "reach: expected a Reach tuple of 10 fields");
        return -1;
    }
    if (world_get(PyTuple_GET_ITEM(o, 0), &rb->wb, 11) < 0) return -1;
    double margin = PyFloat_AsDouble(PyTuple_GET_ITEM(o, 8));
    if (margin == -1.0 && PyErr_Occurred()) goto fail;
    if (get_buf(PyTuple_GET_ITEM(o, 1), &rb->cols, T_F64, 2, 0, "reach.cols") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 2), &rb->memo, T_I64, 1, 1, "reach.memo") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 3), &rb->table, T_F64, 3, 0, "reach.table") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 4), &rb->off, T_I64, 1, 0, "reach.table_off") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 5), &rb->steps, T_F64, 1, 0, "reach.steps") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 6), &rb->start, T_F64, 1, 0, "reach.start_m") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 7), &rb->goal, T_F64, 1, 0, "reach.goal_m") < 0 ||
        get_buf(PyTuple_GET_ITEM(o, 9), &rb->counts, T_I64, 1, 1, "reach.counts") < 0)
        goto fail;
    int64_t nkeys = dim(&rb->memo, 0);
    if (need(dim(&rb->cols, 1) == 4 && dim(&rb->cols, 0) >= 2 &&
                 dim(&rb->table, 0) == dim(&rb->cols, 0) && dim(&rb->off, 0) == 2 &&
                 dim(&rb->steps, 0) == 3 && dim(&rb->start, 0) == 3 && dim(&rb->goal, 0) == 3 &&
                 dim(&rb->counts, 0) >= 2 && nkeys > 0 && (nkeys & (nkeys - 1)) == 0,
             "reach: inconsistent arrays") < 0)
        goto fail;
    r->w = rb->wb.w;
    r->cols = F64(rb->cols);
    r->ncols = dim(&rb->cols, 0);
    r->dy = F64(rb->steps)[1];
    r->dz = F64(rb->steps)[2];
    r->margin = margin;
    r->lim = margin_limit(margin);
    r->tab = F64(rb->table);
    r->tn0 = dim(&rb->table, 0);
    r->tny = dim(&rb->table, 1);
    r->tnz = dim(&rb->table, 2);
    r->off = I64(rb->off);
    r->keys = I64(rb->memo);
    r->nkeys = nkeys;
    r->start_m = F64(rb->start);
    r->goal_m = F64(rb->goal);
    r->counts = I64(rb->counts);
    return 0;
fail:
    reach_release(rb);
    return -1;
}

/* Columns j are 1-based inner columns: 1 <= j <= D - 1 (the table has D + 1 rows). */
static int check_col(long long j, const Reach *r) {
    if (j < 1 || j > r->ncols - 2) {
        PyErr_SetString(PyExc_IndexError, "column index out of range");
        return -1;
    }
    return 0;
}

/* node_status(j, y0, z0, y1, z1, cols, dy, dz, lim, tab, off, keys) */
static PyObject *py_node_status(PyObject *self, PyObject *args) {
    long long j;
    double y0, z0, y1, z1, dy, dz, lim;
    PyObject *oc, *ot, *oo, *ok;
    Buf bc = {0}, bt = {0}, bo = {0}, bk = {0};
    Reach r;
    memset(&r, 0, sizeof(r));
    if (!PyArg_ParseTuple(args, "LddddOdddOOO", &j, &y0, &z0, &y1, &z1, &oc, &dy, &dz, &lim,
                          &ot, &oo, &ok))
        return NULL;
    PyObject *ret = NULL;
    if (get_buf(oc, &bc, T_F64, 2, 0, "cols") < 0 || get_buf(ot, &bt, T_F64, 3, 0, "tab") < 0 ||
        get_buf(oo, &bo, T_I64, 1, 0, "off") < 0 || get_buf(ok, &bk, T_I64, 1, 0, "keys") < 0)
        goto done;
    int64_t nkeys = dim(&bk, 0);
    if (need(dim(&bc, 1) == 4 && dim(&bt, 0) == dim(&bc, 0) && dim(&bo, 0) == 2 && nkeys > 0 &&
                 (nkeys & (nkeys - 1)) == 0 && j >= 1 && j <= dim(&bc, 0) - 2,
             "node_status: inconsistent arrays or column out of range") < 0)
        goto done;
    r.cols = F64(bc);
    r.ncols = dim(&bc, 0);
    r.dy = dy;
    r.dz = dz;
    r.lim = lim;
    r.tab = F64(bt);
    r.tn0 = dim(&bt, 0);
    r.tny = dim(&bt, 1);
    r.tnz = dim(&bt, 2);
    r.off = I64(bo);
    r.keys = I64(bk);
    r.nkeys = nkeys;
    ret = PyLong_FromLong(node_status(j, y0, z0, y1, z1, &r));
done:
    rel(&bc);
    rel(&bt);
    rel(&bo);
    rel(&bk);
    return ret;
}

/* node_resolve(j, y0, z0, y1, z1, cols, dy, dz, start_m, goal_m, world, margin, keys) */
static PyObject *py_node_resolve(PyObject *self, PyObject *args) {
    long long j;
    double y0, z0, y1, z1, dy, dz, margin;
    PyObject *oc, *os, *og, *wt, *ok;
    Buf bc = {0}, bs = {0}, bg = {0}, bk = {0};
    WorldBufs wb;
    Reach r;
    memset(&r, 0, sizeof(r));
    if (!PyArg_ParseTuple(args, "LddddOddOOOdO", &j, &y0, &z0, &y1, &z1, &oc, &dy, &dz, &os,
                          &og, &wt, &margin, &ok))
        return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(oc, &bc, T_F64, 2, 0, "cols") < 0 || get_buf(os, &bs, T_F64, 1, 0, "start_m") < 0 ||
        get_buf(og, &bg, T_F64, 1, 0, "goal_m") < 0 || get_buf(ok, &bk, T_I64, 1, 1, "keys") < 0)
        goto done;
    int64_t nkeys = dim(&bk, 0);
    if (need(dim(&bc, 1) == 4 && dim(&bs, 0) == 3 && dim(&bg, 0) == 3 && nkeys > 0 &&
                 (nkeys & (nkeys - 1)) == 0 && j >= 1 && j <= dim(&bc, 0) - 2,
             "node_resolve: inconsistent arrays or column out of range") < 0)
        goto done;
    r.w = wb.w;
    r.cols = F64(bc);
    r.ncols = dim(&bc, 0);
    r.dy = dy;
    r.dz = dz;
    r.start_m = F64(bs);
    r.goal_m = F64(bg);
    r.margin = margin;
    r.keys = I64(bk);
    r.nkeys = nkeys;
    ret = PyLong_FromLong(node_resolve(j, y0, z0, y1, z1, &r));
done:
    rel(&bc);
    rel(&bs);
    rel(&bg);
    rel(&bk);
    world_release(&wb);
    return ret;
}

/* reachable(j, y0, z0, y1, z1, reach) -> 0/1 (+2 when the exact test ran); not counted */
static PyObject *py_reachable(PyObject *self, PyObject *args) {
    long long j;
    double y0, z0, y1, z1;
    PyObject *ro;
    Reach r;
    ReachBufs rb;
    if (!PyArg_ParseTuple(args, "LddddO", &j, &y0, &z0, &y1, &z1, &ro)) return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    if (check_col(j, &r) < 0) {
        reach_release(&rb);
        return NULL;
    }
    int code = reachable(j, y0, z0, y1, z1, &r);
    reach_release(&rb);
    return PyLong_FromLong(code);
}

/* clearance_table(cols, ylim, iy_lo, iy_hi, iz_lo, iz_hi, dy, dz, world, tab) with tab
 * pre-filled with cap; cap = tab's fill value is passed too */
static PyObject *py_clearance_table(PyObject *self, PyObject *args) {
    PyObject *oc, *ol, *wt, *ot;
    long long iy_lo, iy_hi, iz_lo, iz_hi;
    double dy, dz, cap;
    Buf bc = {0}, bl = {0}, bt = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOLLLLddOdO", &oc, &ol, &iy_lo, &iy_hi, &iz_lo, &iz_hi, &dy,
                          &dz, &wt, &cap, &ot))
        return NULL;
    if (world_get(wt, &wb, 7) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(oc, &bc, T_F64, 2, 0, "cols") < 0 || get_buf(ol, &bl, T_F64, 2, 0, "ylim") < 0 ||
        get_buf(ot, &bt, T_F64, 3, 1, "tab") < 0)
        goto done;
    const World *w = &wb.w;
    int64_t n_cols = dim(&bc, 0) - 1;
    int64_t ny = iy_hi - iy_lo + 1;
    int64_t nz = iz_hi - iz_lo + 1;
    if (need(n_cols >= 0 && dim(&bc, 1) == 4 && dim(&bl, 0) == n_cols + 1 &&
                 dim(&bl, 1) == 2 && dim(&bt, 0) == n_cols + 1 && dim(&bt, 1) == ny &&
                 dim(&bt, 2) == nz,
             "clearance_table: inconsistent shapes") < 0)
        goto done;
    const double *cols = F64(bc), *ylim = F64(bl);
    double *tab = F64(bt);
    double t_lo = iy_lo * dy;
    double t_hi = iy_hi * dy;
    for (int64_t j = 0; j < n_cols + 1; j++) {
        double cx = cols[4 * j], cy = cols[4 * j + 1], nxx = cols[4 * j + 2],
               nyy = cols[4 * j + 3];
        double x_a = cx + t_lo * nxx;
        double x_b = cx + t_hi * nxx;
        double y_a = cy + t_lo * nyy;
        double y_b = cy + t_hi * nyy;
        for (int64_t k = 0; k < w->npieces; k++) {
            const double *bk = w->box + 5 * k;
            double x0 = bk[0] - cap;
            double x1 = bk[1] + cap;
            double y0 = bk[2] - cap;
            double y1 = bk[3] + cap;
            if (dmax(x_a, x_b) < x0 || dmin(x_a, x_b) > x1 || dmax(y_a, y_b) < y0 ||
                dmin(y_a, y_b) > y1)
                continue;
            double lo = t_lo;
            double hi = t_hi;
            if (fabs(nxx) < 1e-12) {
                if (cx < x0 || cx > x1) continue;
            } else {
                double ta = (x0 - cx) / nxx;
                double tb = (x1 - cx) / nxx;
                lo = dmax(lo, dmin(ta, tb));
                hi = dmin(hi, dmax(ta, tb));
            }
            if (fabs(nyy) < 1e-12) {
                if (cy < y0 || cy > y1) continue;
            } else {
                double ta = (y0 - cy) / nyy;
                double tb = (y1 - cy) / nyy;
                lo = dmax(lo, dmin(ta, tb));
                hi = dmin(hi, dmax(ta, tb));
            }
            if (lo > hi) continue;
            int64_t a0 = imax(0, (int64_t)floor(lo / dy) - iy_lo);
            int64_t a1 = imin(ny - 1, (int64_t)ceil(hi / dy) - iy_lo);
            double h = k < w->npoly ? w->poly_h[k] : w->circ[4 * (k - w->npoly) + 3];
            int64_t c0, c1;
            double z_on;
            if (h < 0.0) { /* a ceiling piece from -h up: nodes from -h - cap */
                c0 = imax(0, (int64_t)floor((-h - cap) / dz) - iz_lo);
                c1 = nz - 1;
                z_on = -h;
            } else {
                c0 = 0;
                c1 = imin(nz - 1, (int64_t)ceil((h + cap) / dz) - iz_lo);
                z_on = h;
            }
            for (int64_t a = a0; a <= a1; a++) {
                double yu = (double)(a + iy_lo);
                double px = cols[4 * j + 0] + yu * dy * cols[4 * j + 2];
                double py = cols[4 * j + 1] + yu * dy * cols[4 * j + 3];
                /* the horizontal distance is the same at every height: one 2-D test per node
                 * column, then sqrt(dh^2 + dz^2) (what point_piece_dist computes) per height */
                double dh = point_piece_dist(px, py, z_on, k, w);
                if (dh >= cap) continue;
                for (int64_t c = c0; c <= c1; c++) {
                    double vz = dz_of((double)(c + iz_lo) * dz, h);
                    double d = sqrt(dh * dh + vz * vz);
                    double *t = tab + (j * ny + a) * nz + c;
                    if (d < *t) *t = d;
                }
            }
        }
    }
    double eps = 1e-9;
    for (int64_t j = 0; j < n_cols + 1; j++) {
        for (int64_t a = 0; a < ny; a++) {
            int64_t yu = a + iy_lo;
            double px = cols[4 * j + 0] + (double)yu * dy * cols[4 * j + 2];
            double py = cols[4 * j + 1] + (double)yu * dy * cols[4 * j + 3];
            int lateral_ok = ylim[2 * j] - eps <= yu && yu <= ylim[2 * j + 1] + eps;
            for (int64_t c = 0; c < nz; c++) {
                double z = (double)(c + iz_lo) * dz;
                int inside = lateral_ok && w->zlim[0] - eps <= z && z <= w->zlim[1] + eps;
                for (Py_ssize_t i = 0; i < w->nhp; i++) {
                    const double *h = w->hp + 3 * i;
                    if (h[0] * px + h[1] * py > h[2] + eps) inside = 0;
                }
                if (!inside) tab[(j * ny + a) * nz + c] = -1.0;
            }
        }
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&bc);
    rel(&bl);
    rel(&bt);
    world_release(&wb);
    return ret;
}

/* --- random streams --- */

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

static double ZKN[128], ZWN[128], ZFN[128];
#define ZR 3.442619855899

static void ziggurat_init(void) {
    double m1 = 2147483648.0;
    double dn = 3.442619855899;
    double tn = dn;
    double vn = 9.91256303526217e-3;
    double q = vn / exp(-0.5 * dn * dn);
    memset(ZKN, 0, sizeof(ZKN));
    memset(ZWN, 0, sizeof(ZWN));
    memset(ZFN, 0, sizeof(ZFN));
    ZKN[0] = (dn / q) * m1;
    ZKN[1] = 0.0;
    ZWN[0] = q / m1;
    ZWN[127] = dn / m1;
    ZFN[0] = 1.0;
    ZFN[127] = exp(-0.5 * dn * dn);
    for (int i = 126; i > 0; i--) {
        dn = sqrt(-2.0 * log(vn / dn + exp(-0.5 * dn * dn)));
        ZKN[i + 1] = (dn / tn) * m1;
        tn = dn;
        ZFN[i] = exp(-0.5 * dn * dn);
        ZWN[i] = dn / m1;
    }
}

static double randn_tail(uint64_t *st, double hz, int iz) {
    for (;;) {
        double x = hz * ZWN[iz];
        if (iz == 0) {
            double y;
            for (;;) {
                x = -log(1.0 - rand_u(st)) / ZR;
                y = -log(1.0 - rand_u(st));
                if (y + y >= x * x) break;
            }
            return hz > 0 ? ZR + x : -ZR - x;
        }
        if (ZFN[iz] + rand_u(st) * (ZFN[iz - 1] - ZFN[iz]) < exp(-0.5 * x * x)) return x;
        uint64_t u = next_u64(st);
        iz = (int)(u & 127u);
        hz = (double)(int32_t)(uint32_t)(u >> 32);
        if (fabs(hz) < ZKN[iz]) return hz * ZWN[iz];
    }
}

static inline double randn(uint64_t *st) {
    uint64_t u = next_u64(st);
    int iz = (int)(u & 127u);
    double hz = (double)(int32_t)(uint32_t)(u >> 32);
    if (fabs(hz) < ZKN[iz]) return hz * ZWN[iz];
    return randn_tail(st, hz, iz);
}

enum { DRAW_NONE = 0, DRAW_UNIFORM = 1, DRAW_SYMMETRIC = 2, DRAW_NORMAL = 3 };

static inline double draw_kind(int64_t kind, uint64_t *st) {
    if (kind == DRAW_UNIFORM) return rand_u(st);
    if (kind == DRAW_SYMMETRIC) return 2.0 * rand_u(st) - 1.0;
    if (kind == DRAW_NORMAL) return randn(st);
    return 0.0;
}

/* ziggurat_tables() -> (kn, wn, fn) as tuples of floats (for tests) */
static PyObject *py_ziggurat_tables(PyObject *self, PyObject *noargs) {
    PyObject *t[3];
    double *src[3] = {ZKN, ZWN, ZFN};
    for (int a = 0; a < 3; a++) {
        t[a] = PyTuple_New(128);
        if (t[a] == NULL) {
            for (int b = 0; b < a; b++) Py_DECREF(t[b]);
            return NULL;
        }
        for (int i = 0; i < 128; i++) PyTuple_SET_ITEM(t[a], i, PyFloat_FromDouble(src[a][i]));
    }
    return Py_BuildValue("(NNN)", t[0], t[1], t[2]);
}

/* stream_draws(seed, kind, n) -> list of n draws (for tests) */
static PyObject *py_stream_draws(PyObject *self, PyObject *args) {
    unsigned long long seed;
    long long kind, n;
    if (!PyArg_ParseTuple(args, "KLL", &seed, &kind, &n)) return NULL;
    if (n < 0) return need(0, "n < 0"), NULL;
    uint64_t st = seed;
    PyObject *out = PyList_New(n);
    if (out == NULL) return NULL;
    for (long long i = 0; i < n; i++) {
        PyObject *v = kind < 0 ? PyLong_FromUnsignedLongLong(next_u64(&st))
                               : PyFloat_FromDouble(draw_kind(kind, &st));
        if (v == NULL) {
            Py_DECREF(out);
            return NULL;
        }
        PyList_SET_ITEM(out, i, v);
    }
    return out;
}

/* --- numpy's bit generator (the initialisation draws from the caller's Generator) --- */

typedef struct {
    void *state;
    uint64_t (*next_uint64)(void *st);
    uint32_t (*next_uint32)(void *st);
    double (*next_double)(void *st);
    uint64_t (*next_raw)(void *st);
} bitgen_t;

static inline double window_draw(double t, double h, double lo, double hi, bitgen_t *bg) {
    double u = bg->next_double(bg->state);
    if (t - h >= lo && t + h <= hi) return t + (2.0 * u - 1.0) * h;
    double a = dmax(t - h, lo);
    double b = dmin(t + h, hi);
    if (a > b) {
        if (t + h < lo) {
            a = lo;
            b = dmin(hi, lo + h);
        } else {
            b = hi;
            a = dmax(lo, hi - h);
        }
    }
    return a + u * (b - a);
}

/* sign_draws(capsule, out): out (float64, any shape) filled with ±1, 2·b − 1 for b the top bit
 * of each of the bit generator's next 32-bit draws; for numpy's Generator this is
 * 2.0 · rng.integers(0, 2, size) − 1.0 draw for draw (Lemire's bounded draw of {0, 1} keeps
 * the top bit of a 32-bit draw and never rejects), at a fraction of its cost. The caller holds
 * the bit generator's lock. */
static PyObject *py_sign_draws(PyObject *self, PyObject *args) {
    PyObject *cap, *oo;
    Buf bo = {0};
    if (!PyArg_ParseTuple(args, "OO", &cap, &oo)) return NULL;
    bitgen_t *bg = PyCapsule_GetPointer(cap, "BitGenerator");
    if (bg == NULL) return NULL;
    if (get_buf(oo, &bo, T_F64, -1, 1, "out") < 0) return NULL;
    double *out = F64(bo);
    Py_ssize_t n = bo.view.len / (Py_ssize_t)sizeof(double);
    for (Py_ssize_t i = 0; i < n; i++) {
        uint32_t u = bg->next_uint32(bg->state);
        out[i] = 2.0 * (double)(u >> 31) - 1.0;
    }
    rel(&bo);
    return Py_NewRef(Py_None);
}

/* init_population(n_pop, n_inner, start_u, goal_u, half_window, t_max, max_attempts, window,
 * reach, capsule, nodes, ok) -> deadlocks */
static PyObject *py_init_population(PyObject *self, PyObject *args) {
    long long n_pop, n_inner, t_max, max_attempts;
    double half_window;
    PyObject *osu, *ogu, *ow, *ro, *cap, *on, *ook;
    Buf bsu = {0}, bgu = {0}, bw = {0}, bn = {0}, bok = {0};
    Reach r;
    ReachBufs rb;
    if (!PyArg_ParseTuple(args, "LLOOdLLOOOOO", &n_pop, &n_inner, &osu, &ogu, &half_window,
                          &t_max, &max_attempts, &ow, &ro, &cap, &on, &ook))
        return NULL;
    bitgen_t *bg = PyCapsule_GetPointer(cap, "BitGenerator");
    if (bg == NULL) return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(osu, &bsu, T_F64, 1, 0, "start_u") < 0 ||
        get_buf(ogu, &bgu, T_F64, 1, 0, "goal_u") < 0 ||
        get_buf(ow, &bw, T_F64, 2, 0, "window") < 0 ||
        get_buf(on, &bn, T_F64, 3, 1, "nodes") < 0 || get_buf(ook, &bok, T_BOOL, 1, 1, "ok") < 0)
        goto done;
    if (need(dim(&bsu, 0) >= 2 && dim(&bgu, 0) >= 2 && dim(&bw, 0) >= n_inner + 1 &&
                 dim(&bw, 1) == 4 && dim(&bn, 0) == n_pop && dim(&bn, 1) == n_inner &&
                 dim(&bn, 2) == 2 && dim(&bok, 0) == n_pop && n_inner <= r.ncols - 2,
             "init_population: inconsistent shapes") < 0)
        goto done;
    const double *start_u = F64(bsu), *goal_u = F64(bgu), *window = F64(bw);
    double *nodes = F64(bn);
    unsigned char *ok = BOOL(bok);
    int64_t n_chk = 0, n_exact = 0, deadlocks = 0;
    for (int64_t g = 0; g < n_pop; g++) {
        for (int64_t att = 0; att < max_attempts; att++) {
            double py = start_u[0];
            double pz = start_u[1];
            int alive = 1;
            for (int64_t j = 1; j < n_inner + 1; j++) {
                int64_t m = n_inner + 1 - (j - 1);
                double ty = py + (goal_u[0] - py) / (double)m;
                double tz = pz + (goal_u[1] - pz) / (double)m;
                int placed = 0;
                double ny = 0.0, nz = 0.0;
                const double *wj = window + 4 * j;
                for (int64_t t = 0; t < t_max; t++) {
                    ny = round_grid(window_draw(ty, half_window, wj[0], wj[1], bg));
                    nz = round_grid(window_draw(tz, half_window, wj[2], wj[3], bg));
                    int code = reachable(j, py, pz, ny, nz, &r);
                    n_chk += 1;
                    n_exact += code >> 1;
                    if (code & 1) {
                        placed = 1;
                        break;
                    }
                }
                if (!placed) {
                    alive = 0;
                    break;
                }
                nodes[(g * n_inner + (j - 1)) * 2 + 0] = ny;
                nodes[(g * n_inner + (j - 1)) * 2 + 1] = nz;
                py = ny;
                pz = nz;
            }
            if (alive) {
                ok[g] = 1;
                break;
            }
            deadlocks += 1;
        }
    }
    r.counts[0] += n_chk;
    r.counts[1] += n_exact;
    ret = PyLong_FromLongLong(deadlocks);
done:
    rel(&bsu);
    rel(&bgu);
    rel(&bw);
    rel(&bn);
    rel(&bok);
    reach_release(&rb);
    return ret;
}

/* rebuild(base, active, anchor, offset, spread, draw, spread2, draw2, clamp, first, use_first,
 * explicit, n_explicit, escape, t_max, v_min, v_max, reach, seeds, out, ok) -> escapes */
/* (rebuild_core and mar_core work on the individuals g0 .. g1 − 1: the fused step's threads
 * take one at a time; everyone else passes 0, n_pop) */
/* The generic proposal-and-repair step (see rebuild in uavplan/planners/_kernels.py) on raw
 * arrays. ``offset`` and ``spread2`` may be NULL (all zeros), ``draw2`` NULL (no second
 * draw), ``first`` / ``use_first`` NULL (no first attempts), ``explicit_`` NULL when
 * ``n_att`` is 0. Returns the escapes used; adds the checks made to *n_chk, *n_exact. */
static int64_t rebuild_core(const double *base, int64_t n_pop, int64_t n_inner,
                            const unsigned char *active, const double *anchor,
                            const double *offset, const double *spread, const int64_t *draw,
                            const double *spread2, const int64_t *draw2, const double *clamp,
                            const double *first, const unsigned char *use_first,
                            const double *explicit_, const int64_t *n_explicit,
                            const unsigned char *escape, int64_t t_max, int64_t v_min,
                            int64_t v_max, const Reach *rp, const uint64_t *seeds, double *out,
                            unsigned char *ok, int64_t *n_chk_out, int64_t *n_exact_out,
                            int64_t g0, int64_t g1) {
    const Reach r = *rp;
    int64_t n_chk = 0, n_exact = 0, esc_total = 0;
    int64_t m = n_inner * 2;
    for (int64_t g = g0; g < g1; g++) {
        ok[g] = 1;
        if (!active[g]) memcpy(out + g * m, base + g * m, sizeof(double) * m);
    }
    for (int64_t g = g0; g < g1; g++) {
        if (!active[g]) continue;
        uint64_t st = seeds[g];
        int64_t kind1 = draw[g];
        int64_t kind2 = draw2 ? draw2[g] : DRAW_NONE;
        int64_t n_exp = n_explicit ? n_explicit[g] : 0;
        double py = 0.0;
        double pz = 0.0;
        int same = 1;
        const double *bg_ = base + g * n_inner * 2;
        for (int64_t j = 0; j < n_inner; j++) {
            int placed = 0;
            double ny = 0.0;
            double nz = 0.0;
            int64_t gj = (g * n_inner + j) * 2;
            for (int64_t attempt = 0; attempt < t_max; attempt++) {
                for (int a = 0; a < 2; a++) {
                    double v;
                    if (attempt < n_exp) {
                        v = explicit_[(attempt * n_pop * n_inner) * 2 + gj + a];
                    } else if (attempt == 0 && use_first && use_first[g]) {
                        v = first[gj + a];
                    } else {
                        double step = (offset ? offset[gj + a] : 0.0) + spread[gj + a] * draw_kind(kind1, &st);
                        step = step + (spread2 ? spread2[gj + a] : 0.0) * draw_kind(kind2, &st);
                        double c = clamp[a];
                        if (step > c)
                            step = c;
                        else if (step < -c)
                            step = -c;
                        v = anchor[gj + a] + step;
                    }
                    if (a == 0)
                        ny = round_grid(v);
                    else
                        nz = round_grid(v);
                }
                if (same && ny == bg_[2 * j] && nz == bg_[2 * j + 1]) {
                    placed = 1;
                    break;
                }
                int code = reachable(j + 1, py, pz, ny, nz, &r);
                n_chk += 1;
                n_exact += code >> 1;
                if (code & 1) {
                    placed = 1;
                    break;
                }
            }
            if (!placed && escape[g]) {
                for (int64_t v = v_min; v < v_max + 1; v++) {
                    for (int64_t t = 0; t < t_max; t++) {
                        ny = round_grid(bg_[2 * j] + (2.0 * rand_u(&st) - 1.0) * (double)v);
                        nz = round_grid(bg_[2 * j + 1] + (2.0 * rand_u(&st) - 1.0) * (double)v);
                        int code = reachable(j + 1, py, pz, ny, nz, &r);
                        n_chk += 1;
                        n_exact += code >> 1;
                        if (code & 1) {
                            placed = 1;
                            break;
                        }
                    }
                    if (placed) {
                        esc_total += 1;
                        break;
                    }
                }
            }
            if (!placed) {
                ny = bg_[2 * j];
                nz = bg_[2 * j + 1];
                if (!same) {
                    int code = reachable(j + 1, py, pz, ny, nz, &r);
                    n_chk += 1;
                    n_exact += code >> 1;
                    placed = (code & 1) == 1;
                } else {
                    placed = 1;
                }
            }
            if (!placed) {
                ok[g] = 0;
                break;
            }
            out[gj] = ny;
            out[gj + 1] = nz;
            same = ny == bg_[2 * j] && nz == bg_[2 * j + 1];
            py = ny;
            pz = nz;
        }
        if (!ok[g]) memcpy(out + g * n_inner * 2, bg_, sizeof(double) * n_inner * 2);
    }
    *n_chk_out += n_chk;
    *n_exact_out += n_exact;
    return esc_total;
}

static PyObject *py_rebuild(PyObject *self, PyObject *args) {
    PyObject *o[14], *ro, *oseeds, *oout, *ook;
    long long t_max, v_min, v_max;
    enum { BASE, ACTIVE, ANCHOR, OFFSET, SPREAD, DRAW1, SPREAD2, DRAW2, CLAMP, FIRST, USEFIRST,
           EXPLICIT, NEXPLICIT, ESCAPE, NB };
    static const char *names[NB] = {"base",  "active",  "anchor",    "offset",     "spread",
                                    "draw",  "spread2", "draw2",     "clamp",      "first",
                                    "use_first", "explicit", "n_explicit", "escape"};
    static const int types[NB] = {T_F64, T_BOOL, T_F64, T_F64, T_F64, T_I64, T_F64,
                                  T_I64, T_F64, T_F64, T_BOOL, T_F64, T_I64, T_BOOL};
    static const int ndims[NB] = {3, 1, 3, 3, 3, 1, 3, 1, 1, 3, 1, 4, 1, 1};
    Buf b[NB], bseeds = {0}, bout = {0}, bok = {0};
    Reach r;
    ReachBufs rb;
    memset(b, 0, sizeof(b));
    if (!PyArg_ParseTuple(args, "OOOOOOOOOOOOOOLLLOOOO", &o[0], &o[1], &o[2], &o[3], &o[4],
                          &o[5], &o[6], &o[7], &o[8], &o[9], &o[10], &o[11], &o[12], &o[13],
                          &t_max, &v_min, &v_max, &ro, &oseeds, &oout, &ook))
        return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    PyObject *ret = NULL;
    for (int i = 0; i < NB; i++)
        if (get_buf(o[i], &b[i], types[i], ndims[i], 0, names[i]) < 0) goto done;
    if (get_buf(oseeds, &bseeds, T_U64, 1, 0, "seeds") < 0 ||
        get_buf(oout, &bout, T_F64, 3, 1, "out") < 0 || get_buf(ook, &bok, T_BOOL, 1, 1, "ok") < 0)
        goto done;
    int64_t n_pop = dim(&b[BASE], 0);
    int64_t n_inner = dim(&b[BASE], 1);
    int64_t n_att = dim(&b[EXPLICIT], 0);
    {
        int shapes_ok = dim(&b[BASE], 2) == 2 && n_inner <= r.ncols - 2 &&
                        dim(&b[CLAMP], 0) == 2 && dim(&bseeds, 0) == n_pop &&
                        dim(&bok, 0) == n_pop;
        int g3[] = {ANCHOR, OFFSET, SPREAD, SPREAD2, FIRST};
        for (int i = 0; i < 5; i++)
            shapes_ok = shapes_ok && dim(&b[g3[i]], 0) == n_pop &&
                        dim(&b[g3[i]], 1) == n_inner && dim(&b[g3[i]], 2) == 2;
        shapes_ok = shapes_ok && dim(&bout, 0) == n_pop && dim(&bout, 1) == n_inner &&
                    dim(&bout, 2) == 2;
        int g1[] = {ACTIVE, DRAW1, DRAW2, USEFIRST, NEXPLICIT, ESCAPE};
        for (int i = 0; i < 6; i++) shapes_ok = shapes_ok && dim(&b[g1[i]], 0) == n_pop;
        shapes_ok = shapes_ok && (n_att == 0 || (dim(&b[EXPLICIT], 1) == n_pop &&
                                                 dim(&b[EXPLICIT], 2) == n_inner &&
                                                 dim(&b[EXPLICIT], 3) == 2));
        if (need(shapes_ok, "rebuild: inconsistent shapes") < 0) goto done;
        const int64_t *nexp = I64(b[NEXPLICIT]);
        for (int64_t g = 0; g < n_pop; g++)
            if (need(nexp[g] <= n_att || t_max <= n_att,
                     "rebuild: n_explicit larger than explicit's first axis") < 0)
                goto done;
    }
    const double *base = F64(b[BASE]), *anchor = F64(b[ANCHOR]), *offset = F64(b[OFFSET]);
    const double *spread = F64(b[SPREAD]), *spread2 = F64(b[SPREAD2]), *clamp = F64(b[CLAMP]);
    const double *first = F64(b[FIRST]), *explicit_ = F64(b[EXPLICIT]);
    const unsigned char *active = BOOL(b[ACTIVE]), *use_first = BOOL(b[USEFIRST]),
                        *escape = BOOL(b[ESCAPE]);
    const int64_t *draw = I64(b[DRAW1]), *draw2 = I64(b[DRAW2]), *n_explicit = I64(b[NEXPLICIT]);
    const uint64_t *seeds = U64(bseeds);
    double *out = F64(bout);
    unsigned char *ok = BOOL(bok);
    int64_t n_chk = 0, n_exact = 0;
    int64_t esc_total = rebuild_core(base, n_pop, n_inner, active, anchor, offset, spread, draw,
                                     spread2, draw2, clamp, first, use_first, explicit_,
                                     n_explicit, escape, t_max, v_min, v_max, &r, seeds, out, ok,
                                     &n_chk, &n_exact, 0, n_pop);
    r.counts[0] += n_chk;
    r.counts[1] += n_exact;
    ret = PyLong_FromLongLong(esc_total);
done:
    for (int i = 0; i < NB; i++) rel(&b[i]);
    rel(&bseeds);
    rel(&bout);
    rel(&bok);
    reach_release(&rb);
    return ret;
}

/* moving_average_repair(nodes, goal_u, window, reach, skip, moved) */
/* Eq. 13's moving-average repair (see moving_average_repair in
 * uavplan/planners/_kernels.py) on raw arrays; ``new_`` is scratch for 2·n_inner values. */
static void mar_core(double *nodes, int64_t n_pop, int64_t n_inner, const double *goal_u,
                     int64_t window, const Reach *rp, const unsigned char *skip, int64_t *moved,
                     double *new_, int64_t *n_chk_out, int64_t *n_exact_out, int64_t g0,
                     int64_t g1) {
    const Reach r = *rp;
    int64_t n_chk = 0, n_exact = 0;
    double dy = r.dy, dz = r.dz;
    for (int64_t g = g0; g < g1; g++) {
        if (skip[g]) continue;
        double *ng = nodes + g * n_inner * 2;
        double py = 0.0;
        double pz = 0.0;
        int ok = 1;
        int64_t count = 0;
        int same = 1;
        for (int64_t j = 0; j < n_inner; j++) {
            int placed = 0;
            double ny = 0.0, nz = 0.0;
            for (int64_t np_ = window; np_ > 2; np_--) {
                double sy = j > 0 ? py : r.start_m[1] / dy;
                double sz = j > 0 ? pz : r.start_m[2] / dz;
                int64_t cnt = 1;
                /* the window's nodes, then the goal if the window reaches past the last node */
                int64_t k_end = imin(j + np_ - 1, n_inner);
                for (int64_t k = j; k < k_end; k++) {
                    sy += ng[2 * k];
                    sz += ng[2 * k + 1];
                    cnt += 1;
                }
                if (j + np_ - 1 > n_inner) {
                    sy += goal_u[0];
                    sz += goal_u[1];
                    cnt += 1;
                }
                ny = round_grid(sy / (double)cnt);
                nz = round_grid(sz / (double)cnt);
                if (same && ny == ng[2 * j] && nz == ng[2 * j + 1]) {
                    placed = 1;
                    break;
                }
                int code = reachable(j + 1, py, pz, ny, nz, &r);
                n_chk += 1;
                n_exact += code >> 1;
                if (code & 1) {
                    placed = 1;
                    break;
                }
            }
            if (!placed) {
                ny = ng[2 * j];
                nz = ng[2 * j + 1];
                if (!same) {
                    int code = reachable(j + 1, py, pz, ny, nz, &r);
                    n_chk += 1;
                    n_exact += code >> 1;
                    if (!(code & 1)) {
                        ok = 0;
                        break;
                    }
                }
            }
            same = ny == ng[2 * j] && nz == ng[2 * j + 1];
            if (!same) count += 1;
            new_[2 * j] = ny;
            new_[2 * j + 1] = nz;
            py = ny;
            pz = nz;
        }
        if (ok) {
            memcpy(ng, new_, sizeof(double) * 2 * n_inner);
            moved[g] = count;
        }
    }
    *n_chk_out += n_chk;
    *n_exact_out += n_exact;
}

static PyObject *py_moving_average_repair(PyObject *self, PyObject *args) {
    PyObject *on, *ogu, *ro, *osk, *om;
    long long window;
    Buf bn = {0}, bgu = {0}, bsk = {0}, bm = {0};
    Reach r;
    ReachBufs rb;
    double *new_ = NULL;
    if (!PyArg_ParseTuple(args, "OOLOOO", &on, &ogu, &window, &ro, &osk, &om)) return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(on, &bn, T_F64, 3, 1, "nodes") < 0 ||
        get_buf(ogu, &bgu, T_F64, 1, 0, "goal_u") < 0 ||
        get_buf(osk, &bsk, T_BOOL, 1, 0, "skip") < 0 || get_buf(om, &bm, T_I64, 1, 1, "moved") < 0)
        goto done;
    int64_t n_pop = dim(&bn, 0);
    int64_t n_inner = dim(&bn, 1);
    if (need(dim(&bn, 2) == 2 && n_inner <= r.ncols - 2 && dim(&bgu, 0) >= 2 &&
                 dim(&bsk, 0) == n_pop && dim(&bm, 0) == n_pop,
             "moving_average_repair: inconsistent shapes") < 0)
        goto done;
    double *nodes = F64(bn);
    const double *goal_u = F64(bgu);
    const unsigned char *skip = BOOL(bsk);
    int64_t *moved = I64(bm);
    new_ = malloc(sizeof(double) * 2 * (n_inner > 0 ? n_inner : 1));
    if (new_ == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    int64_t n_chk = 0, n_exact = 0;
    mar_core(nodes, n_pop, n_inner, goal_u, window, &r, skip, moved, new_, &n_chk, &n_exact, 0,
             n_pop);
    r.counts[0] += n_chk;
    r.counts[1] += n_exact;
    ret = Py_NewRef(Py_None);
done:
    free(new_);
    rel(&bn);
    rel(&bgu);
    rel(&bsk);
    rel(&bm);
    reach_release(&rb);
    return ret;
}

/* paths_feasible(nodes, reach, out) */
static PyObject *py_paths_feasible(PyObject *self, PyObject *args) {
    PyObject *on, *ro, *oo;
    Buf bn = {0}, bo = {0};
    Reach r;
    ReachBufs rb;
    if (!PyArg_ParseTuple(args, "OOO", &on, &ro, &oo)) return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(on, &bn, T_F64, 3, 0, "nodes") < 0 || get_buf(oo, &bo, T_BOOL, 1, 1, "out") < 0)
        goto done;
    int64_t n_pop = dim(&bn, 0);
    int64_t n_inner = dim(&bn, 1);
    if (need(dim(&bn, 2) == 2 && n_inner <= r.ncols - 2 && dim(&bo, 0) == n_pop,
             "paths_feasible: inconsistent shapes") < 0)
        goto done;
    const double *nodes = F64(bn);
    unsigned char *out = BOOL(bo);
    int64_t n_chk = 0, n_exact = 0;
    for (int64_t g = 0; g < n_pop; g++) {
        double py = 0.0, pz = 0.0;
        out[g] = 1;
        for (int64_t j = 0; j < n_inner; j++) {
            double ny = nodes[(g * n_inner + j) * 2];
            double nz = nodes[(g * n_inner + j) * 2 + 1];
            int code = reachable(j + 1, py, pz, ny, nz, &r);
            n_chk += 1;
            n_exact += code >> 1;
            if (!(code & 1)) {
                out[g] = 0;
                break;
            }
            py = ny;
            pz = nz;
        }
    }
    r.counts[0] += n_chk;
    r.counts[1] += n_exact;
    ret = Py_NewRef(Py_None);
done:
    rel(&bn);
    rel(&bo);
    reach_release(&rb);
    return ret;
}

/* ------------------------------------------------------------------------------------------
 * Energy (uavplan/path/energy.py)
 */

static PyObject *py_polyline_energy(PyObject *self, PyObject *args) {
    PyObject *op;
    double k0, k1, mu0, k2;
    Buf bp;
    if (!PyArg_ParseTuple(args, "Odddd", &op, &k0, &k1, &mu0, &k2)) return NULL;
    if (get_buf(op, &bp, T_F64, 2, 0, "points") < 0) return NULL;
    Py_ssize_t n = dim(&bp, 0);
    if (n > 0 && dim(&bp, 1) != 3) {
        rel(&bp);
        return need(0, "points: need (n, 3)"), NULL;
    }
    const double *p = F64(bp);
    double length = 0.0, turn = 0.0, climb = 0.0;
    double pdx = 0.0, pdy = 0.0, pdz = 0.0, plen = 0.0;
    for (Py_ssize_t i = 1; i < n; i++) {
        double dx = p[3 * i] - p[3 * (i - 1)];
        double dy = p[3 * i + 1] - p[3 * (i - 1) + 1];
        double dz = p[3 * i + 2] - p[3 * (i - 1) + 2];
        double seg = sqrt(dx * dx + dy * dy + dz * dz);
        if (seg <= 1e-12) continue;
        length += seg;
        climb += fabs(dz);
        if (plen > 0.0) turn += 1.0 - (pdx * dx + pdy * dy + pdz * dz) / (plen * seg);
        pdx = dx;
        pdy = dy;
        pdz = dz;
        plen = seg;
    }
    rel(&bp);
    return Py_BuildValue("(ddd)", k0 * length, k1 * mu0 * turn, k2 * climb);
}

static void thomas_factors(int64_t n, double *cp, double *den) {
    double prev = 0.0;
    for (int64_t i = 0; i < n; i++) {
        den[i] = 4.0 - prev;
        cp[i] = 1.0 / den[i];
        prev = cp[i];
    }
}

static void second_derivs(const double *vals, int64_t nv, double h, const double *cp,
                          const double *den, double *out) {
    int64_t n = nv - 2;
    out[0] = 0.0;
    out[n + 1] = 0.0;
    if (n <= 0) return;
    double scale = 6.0 / (h * h);
    double prev = 0.0;
    for (int64_t i = 0; i < n; i++) {
        double r = scale * (vals[i] - 2.0 * vals[i + 1] + vals[i + 2]);
        prev = (r - prev) / den[i];
        out[i + 1] = prev;
    }
    for (int64_t i = n - 2; i > -1; i--) out[i + 1] -= cp[i] * out[i + 2];
}

/* second_derivs of two knot sequences at once: the same expressions, in the same order, for
 * each (bit-identical to two calls); the two division chains overlap. */
static void second_derivs2(const double *va, const double *vb, int64_t nv, double h,
                           const double *cp, const double *den, double *oa, double *ob) {
    int64_t n = nv - 2;
    oa[0] = 0.0;
    oa[n + 1] = 0.0;
    ob[0] = 0.0;
    ob[n + 1] = 0.0;
    if (n <= 0) return;
    double scale = 6.0 / (h * h);
    double pa = 0.0, pb = 0.0;
    for (int64_t i = 0; i < n; i++) {
        double ra = scale * (va[i] - 2.0 * va[i + 1] + va[i + 2]);
        double rb = scale * (vb[i] - 2.0 * vb[i + 1] + vb[i + 2]);
        pa = (ra - pa) / den[i];
        pb = (rb - pb) / den[i];
        oa[i + 1] = pa;
        ob[i + 1] = pb;
    }
    for (int64_t i = n - 2; i > -1; i--) {
        oa[i + 1] -= cp[i] * oa[i + 2];
        ob[i + 1] -= cp[i] * ob[i + 2];
    }
}

/* spline_points(ys, zs, dx, n_sub, cp, den, out) */
static PyObject *py_spline_points(PyObject *self, PyObject *args) {
    PyObject *oy, *oz, *ocp, *oden, *oo;
    double dx;
    long long n_sub;
    Buf by = {0}, bz = {0}, bcp = {0}, bden = {0}, bo = {0};
    double *my = NULL;
    if (!PyArg_ParseTuple(args, "OOdLOOO", &oy, &oz, &dx, &n_sub, &ocp, &oden, &oo)) return NULL;
    PyObject *ret = NULL;
    if (get_buf(oy, &by, T_F64, 1, 0, "ys") < 0 || get_buf(oz, &bz, T_F64, 1, 0, "zs") < 0 ||
        get_buf(ocp, &bcp, T_F64, 1, 0, "cp") < 0 || get_buf(oden, &bden, T_F64, 1, 0, "den") < 0 ||
        get_buf(oo, &bo, T_F64, 2, 1, "out") < 0)
        goto done;
    int64_t nk = dim(&by, 0);
    if (need(nk >= 2 && dim(&bz, 0) == nk && n_sub >= 1 && dim(&bcp, 0) >= nk - 2 &&
                 dim(&bden, 0) >= nk - 2 && dim(&bo, 0) == (nk - 1) * n_sub + 1 &&
                 dim(&bo, 1) == 3,
             "spline_points: inconsistent shapes") < 0)
        goto done;
    my = malloc(sizeof(double) * 2 * nk);
    if (my == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *mz = my + nk;
    const double *ys = F64(by), *zs = F64(bz);
    double *out = F64(bo);
    second_derivs(ys, nk, dx, F64(bcp), F64(bden), my);
    second_derivs(zs, nk, dx, F64(bcp), F64(bden), mz);
    double h2 = dx * dx / 6.0;
    int64_t row = 0;
    for (int64_t i = 0; i < nk - 1; i++) {
        for (int64_t k = 0; k < n_sub; k++) {
            double u = (double)k / (double)n_sub;
            double a = 1.0 - u;
            double c = h2 * (a * a * a - a);
            double d = h2 * (u * u * u - u);
            out[3 * row] = ((double)i + u) * dx;
            out[3 * row + 1] = a * ys[i] + u * ys[i + 1] + c * my[i] + d * my[i + 1];
            out[3 * row + 2] = a * zs[i] + u * zs[i + 1] + c * mz[i] + d * mz[i + 1];
            row += 1;
        }
    }
    out[3 * row] = (double)(nk - 1) * dx;
    out[3 * row + 1] = ys[nk - 1];
    out[3 * row + 2] = zs[nk - 1];
    ret = Py_NewRef(Py_None);
done:
    free(my);
    rel(&by);
    rel(&bz);
    rel(&bcp);
    rel(&bden);
    rel(&bo);
    return ret;
}

static void moving_average(const double *vals, int64_t n, int64_t half, double *out) {
    for (int64_t i = 0; i < n; i++) {
        int64_t h = imin(imin(half, i), n - 1 - i);
        double acc = 0.0;
        if (h == 2) {
            /* the fitness's default half-width, unrolled: the same sums in the same order */
            const double *v = vals + i - 2;
            acc = ((((acc + v[0]) + v[1]) + v[2]) + v[3]) + v[4];
        } else {
            for (int64_t k = i - h; k < i + h + 1; k++) acc += vals[k];
        }
        out[i] = acc / (double)(2 * h + 1);
    }
}

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
} Energy;

static int energy_init(Energy *e) {
    int64_t nf = e->inner > 1 ? e->inner : 1;
    int64_t nk = e->inner + 2;
    int64_t ns = (nk - 1) * e->n_sub + 1; /* spline samples, ends included */
    e->work = malloc(sizeof(double) * (2 * nf + 8 * nk + 4 * e->n_sub + 7 * ns));
    if (e->work == NULL) {
        PyErr_NoMemory();
        return -1;
    }
    thomas_factors(nf, e->work, e->work + nf);
    /* the weights depend on the sub-step only: computed once, by the same expressions */
    double h2 = e->dx * e->dx / 6.0;
    e->coef = e->work + 2 * nf + 8 * nk;
    for (int64_t k = 0; k < e->n_sub; k++) {
        double u = (double)k / (double)e->n_sub;
        double a = 1.0 - u;
        e->coef[4 * k] = u;
        e->coef[4 * k + 1] = a;
        e->coef[4 * k + 2] = h2 * (a * a * a - a);
        e->coef[4 * k + 3] = h2 * (u * u * u - u);
    }
    e->samp = e->coef + 4 * e->n_sub;
    double *mx = e->work + 2 * nf + 7 * nk;
    for (int64_t i = 0; i < nk; i++) mx[i] = 0.0;
    return 0;
}

/* Where energy_knots leaves the knots in e->work (after the Thomas factors and the raw
 * knots): sy, then sz, then sx, inner + 2 values each. */
static double *knots_y(const Energy *e) {
    int64_t nf = e->inner > 1 ? e->inner : 1;
    return e->work + 2 * nf + 2 * (e->inner + 2);
}

/* The spline's knots (inner + 2 of them, ends included) in metres, in e->work: sy, sz, and
 * sx unless the frame is straight (a straight frame's x is the column's i·dx). */
static void energy_knots(const double *nodes, const Energy *e) {
    int64_t inner = e->inner;
    int64_t nk = inner + 2;
    int64_t nf = inner > 1 ? inner : 1;
    double *ys = e->work + 2 * nf, *zs = ys + nk, *sy = knots_y(e), *sz = sy + nk, *sx = sz + nk;
    const double *cols = e->cols;
    ys[0] = e->start_yz[0];
    zs[0] = e->start_yz[1];
    ys[nk - 1] = e->goal_yz[0];
    zs[nk - 1] = e->goal_yz[1];
    for (int64_t j = 0; j < inner; j++) {
        ys[j + 1] = nodes[j * 2] * e->dy;
        zs[j + 1] = nodes[j * 2 + 1] * e->dz;
    }
    if (e->smooth > 0) {
        moving_average(ys, nk, e->smooth, sy);
        moving_average(zs, nk, e->smooth, sz);
    } else {
        memcpy(sy, ys, sizeof(double) * nk);
        memcpy(sz, zs, sizeof(double) * nk);
    }
    if (!e->straight) {
        for (int64_t j = 0; j < nk; j++) {
            double lat = sy[j];
            sx[j] = cols[4 * j] + lat * cols[4 * j + 2];
            sy[j] = cols[4 * j + 1] + lat * cols[4 * j + 3];
        }
    }
}

/* Whether energy_bound is a lower bound for these weights: k0, k2, k1·μ0 >= 0 (the
 * configuration's bounds). */
static int bound_valid(const Energy *e) {
    return e->k0 >= 0.0 && e->k2 >= 0.0 && e->k1 * e->mu0 >= 0.0;
}

/* energy_bound of the knots energy_knots left in e->work. */
static double bound_from_knots(const Energy *e) {
    int64_t nk = e->inner + 2;
    const double *sy = knots_y(e), *sz = sy + nk, *sx = sz + nk;
    int straight = e->straight;
    double dx = e->dx;
    double length = 0.0, climb = 0.0;
    for (int64_t j = 1; j < nk; j++) {
        double ex = straight ? dx : sx[j] - sx[j - 1];
        double ey = sy[j] - sy[j - 1], ez = sz[j] - sz[j - 1];
        length += sqrt(ex * ex + ey * ey + ez * ez);
        climb += fabs(ez);
    }
    return e->k0 * length + e->k2 * climb;
}

/* A lower bound of energy_one: k0 · (length of the knots' polyline) + k2 · (its climb). The
 * spline's samples include every knot exactly (u = 0 gives a = 1 and c = d = 0), so the
 * sampled polyline is the knots' polyline with vertices added: by the triangle inequality
 * it is no shorter and climbs no less, and the turn term is >= 0. -1 (no bound) unless
 * bound_valid. */
static double energy_bound(const double *nodes, const Energy *e) {
    if (!bound_valid(e)) return -1.0;
    energy_knots(nodes, e);
    return bound_from_knots(e);
}

/* energy_one of the knots energy_knots left in e->work. */
static double energy_from_knots(const Energy *e) {
    int64_t inner = e->inner;
    int64_t nk = inner + 2;
    int64_t nf = inner > 1 ? inner : 1;
    double *cp = e->work, *den = e->work + nf;
    double *sy = knots_y(e), *sz = sy + nk, *sx = sz + nk;
    double *my = sx + nk, *mz = my + nk, *mx = mz + nk;
    int straight = e->straight;
    int64_t n_sub = e->n_sub;
    double dx = e->dx;
    const double *coef = e->coef;
    if (!straight) second_derivs(sx, nk, dx, cp, den, mx);
    second_derivs2(sy, sz, nk, dx, cp, den, my, mz);
    /* Three passes with the same expressions, in the same order, as one sequential walk
     * over the samples (so the result is the same to the bit), but the first two have no
     * dependency between samples: the samples, then every step's vector and length, then
     * the sums. */
    int64_t ns = (nk - 1) * n_sub + 1;
    double *qx = e->samp, *qy = qx + ns, *qz = qy + ns;
    double *vx = qz + ns, *vy = vx + ns, *vz = vy + ns, *vl = vz + ns;
    qx[0] = straight ? 0.0 : sx[0];
    qy[0] = sy[0];
    qz[0] = sz[0];
    int64_t q = 1;
    for (int64_t i = 0; i < nk - 1; i++) {
        for (int64_t k = (i == 0 ? 1 : 0); k < n_sub; k++) {
            double u = coef[4 * k], a = coef[4 * k + 1], c = coef[4 * k + 2], d = coef[4 * k + 3];
            if (straight)
                qx[q] = ((double)i + u) * dx;
            else
                qx[q] = a * sx[i] + u * sx[i + 1] + c * mx[i] + d * mx[i + 1];
            qy[q] = a * sy[i] + u * sy[i + 1] + c * my[i] + d * my[i + 1];
            qz[q] = a * sz[i] + u * sz[i + 1] + c * mz[i] + d * mz[i + 1];
            q++;
        }
    }
    qx[q] = straight ? (double)(nk - 1) * dx : sx[nk - 1];
    qy[q] = sy[nk - 1];
    qz[q] = sz[nk - 1];
    for (int64_t t = 1; t < ns; t++) {
        double ex = qx[t] - qx[t - 1];
        double ey = qy[t] - qy[t - 1];
        double ez = qz[t] - qz[t - 1];
        vx[t] = ex;
        vy[t] = ey;
        vz[t] = ez;
        vl[t] = sqrt(ex * ex + ey * ey + ez * ez);
    }
    double length = 0.0, turn = 0.0, climb = 0.0;
    double pdx = 0.0, pdy = 0.0, pdz = 0.0, plen = 0.0;
    for (int64_t t = 1; t < ns; t++) {
        double seg = vl[t];
        if (seg > 1e-12) {
            double ex = vx[t], ey = vy[t], ez = vz[t];
            length += seg;
            climb += fabs(ez);
            if (plen > 0.0) turn += 1.0 - (pdx * ex + pdy * ey + pdz * ez) / (plen * seg);
            pdx = ex;
            pdy = ey;
            pdz = ez;
            plen = seg;
        }
    }
    return e->k0 * length + e->k1 * e->mu0 * turn + e->k2 * climb;
}

/* The energy of one individual's inner nodes (inner, 2) in grid units. */
static double energy_one(const double *nodes, const Energy *e) {
    energy_knots(nodes, e);
    return energy_from_knots(e);
}

/* An energy tuple (start_yz, goal_yz, cols, dx, dy, dz, n_sub, k0, k1, mu0, k2, smooth,
 * straight) as PathProblem.energy_args builds it; work buffers allocated by energy_init. */
static int energy_get(PyObject *o, Energy *e, Buf *bufs, int64_t inner) {
    long long n_sub, smooth;
    int straight;
    PyObject *os, *og, *oc;
    memset(e, 0, sizeof(*e));
    if (!PyArg_ParseTuple(o, "OOOdddLddddLp", &os, &og, &oc, &e->dx, &e->dy, &e->dz, &n_sub,
                          &e->k0, &e->k1, &e->mu0, &e->k2, &smooth, &straight))
        return -1;
    if (get_buf(os, &bufs[0], T_F64, 1, 0, "energy.start_yz") < 0 ||
        get_buf(og, &bufs[1], T_F64, 1, 0, "energy.goal_yz") < 0 ||
        get_buf(oc, &bufs[2], T_F64, 2, 0, "energy.cols") < 0)
        return -1;
    if (need(dim(&bufs[0], 0) >= 2 && dim(&bufs[1], 0) >= 2 && n_sub >= 1 &&
                 (straight || (dim(&bufs[2], 0) >= inner + 2 && dim(&bufs[2], 1) == 4)),
             "energy: inconsistent arrays") < 0)
        return -1;
    e->start_yz = F64(bufs[0]);
    e->goal_yz = F64(bufs[1]);
    e->cols = F64(bufs[2]);
    e->n_sub = n_sub;
    e->smooth = smooth;
    e->inner = inner;
    e->straight = straight;
    return energy_init(e);
}

/* fn (energy_one or energy_bound) of every individual of nodes (G, n, 2) into out (G,) */
static PyObject *population_map(PyObject *args, double (*fn)(const double *, const Energy *)) {
    PyObject *on, *oen, *oo;
    Energy e;
    Buf bn = {0}, bo = {0}, ben[3];
    memset(ben, 0, sizeof(ben));
    memset(&e, 0, sizeof(e));
    if (!PyArg_ParseTuple(args, "OOO", &on, &oen, &oo)) return NULL;
    PyObject *ret = NULL;
    if (get_buf(on, &bn, T_F64, 3, 0, "nodes") < 0 || get_buf(oo, &bo, T_F64, 1, 1, "out") < 0)
        goto done;
    int64_t g_count = dim(&bn, 0);
    int64_t inner = dim(&bn, 1);
    if (need(dim(&bn, 2) == 2 && dim(&bo, 0) == g_count,
             "population_energy: inconsistent shapes") < 0)
        goto done;
    if (energy_get(oen, &e, ben, inner) < 0) goto done;
    const double *nodes = F64(bn);
    double *out = F64(bo);
    for (int64_t g = 0; g < g_count; g++) out[g] = fn(nodes + g * inner * 2, &e);
    ret = Py_NewRef(Py_None);
done:
    free(e.work);
    for (int i = 0; i < 3; i++) rel(&ben[i]);
    rel(&bn);
    rel(&bo);
    return ret;
}

/* population_energy(nodes, energy, out): the energy (G,) of nodes (G, n, 2) */
static PyObject *py_population_energy(PyObject *self, PyObject *args) {
    return population_map(args, energy_one);
}

/* energy_bounds(nodes, energy, out): energy_bound (G,) of nodes (G, n, 2) (-1: no bound) */
static PyObject *py_energy_bounds(PyObject *self, PyObject *args) {
    return population_map(args, energy_bound);
}

/* ------------------------------------------------------------------------------------------
 * One SPSA / SSA iteration (uavplan/planners/sparrow.py)
 */

enum {
    SPSA_START_END = 1,  /* contribution 2: producers pulled toward the start-end line */
    SPSA_LITERAL = 2,    /* eq. 11 read literally (else the deviation reading) */
    SPSA_POP_INDEX = 4,  /* eq. 4's i ranked in the whole population (else among scroungers) */
    SPSA_ESCAPE = 8,     /* contribution 3: scroungers may escape (eq. 12) */
    SPSA_OSCILLATE = 16, /* contribution 4: oscillation optimisation (eq. 13) */
};

#define SPSA_EPS 1e-50

/* A cache of recent fitness values (recalled, not recomputed, when a candidate path was seen
 * before): ``slots`` (a power of two) entries, each a path stored as int32 grid values and its
 * energy; a path's slot is picked by a hash of its values, and a hit is a stored path equal
 * to it value for value (nothing else is trusted). Paths with a value that is not an int32
 * (or is −0.0) are not cached. The values are energy_one's: a hit returns exactly what a
 * recomputation would. */
typedef struct {
    unsigned char *filled; /* (slots,) */
    double *vals;          /* (slots,) */
    int32_t *paths;        /* (slots, m) */
    int64_t slots, m;
    int64_t part, nparts;  /* this user's share: the slots s with s mod nparts = part */
} ECache;

/* energy_bound's margin: far above the bound's and the energy's rounding (relative 1e-13) */
#define BOUND_MARGIN 1e-9

/* The path's slot in the cache, or -1 when there is no cache or the path is not cacheable. */
static int64_t cache_slot(const double *path, const ECache *c) {
    if (c == NULL || c->slots == 0) return -1;
    uint64_t h = 0x9E3779B97F4A7C15ULL;
    for (int64_t i = 0; i < c->m; i++) {
        double v = path[i];
        /* an int32 value (in range, the truncation is exact: equal iff v is an integer) */
        if (!(v >= -2147483648.0 && v <= 2147483647.0) || (double)(int32_t)v != v ||
            (v == 0.0 && signbit(v)))
            return -1;
        h = (h ^ (uint64_t)(uint32_t)(int32_t)v) * 0x100000001B3ULL;
    }
    h ^= h >> 29;
    h *= 0xBF58476D1CE4E5B9ULL;
    h ^= h >> 32;
    int64_t slot = (int64_t)(h & (uint64_t)(c->slots - 1));
    if (c->nparts > 1 && slot % c->nparts != c->part) return -1; /* another thread's share */
    return slot;
}

/* The path's energy: energy_one's value, recalled when the cache holds the path. With a
 * finite ``cutoff`` (greedy selection, which only asks whether a candidate beats its parent's
 * fitness), a path that is not cached and whose energy_bound proves its energy >= cutoff
 * gets ``cutoff`` itself, without the energy being computed. */
static double energy_cached(const double *path, const Energy *e, ECache *c, double cutoff) {
    int64_t slot = cache_slot(path, c);
    int32_t *stored = slot >= 0 ? c->paths + slot * c->m : NULL;
    if (slot >= 0 && c->filled[slot]) {
        int64_t i = 0;
        while (i < c->m && stored[i] == (int32_t)path[i]) i++;
        if (i == c->m) return c->vals[slot];
    }
    energy_knots(path, e);
    if (cutoff < INFINITY && bound_valid(e) &&
        bound_from_knots(e) * (1.0 - BOUND_MARGIN) >= cutoff)
        return cutoff;
    double energy = energy_from_knots(e); /* the knots are computed once for both */
    if (slot >= 0) {
        for (int64_t i = 0; i < c->m; i++) stored[i] = (int32_t)path[i];
        c->vals[slot] = energy;
        c->filled[slot] = 1;
    }
    return energy;
}

static int same_path(const double *a, const double *b, int64_t m) {
    for (int64_t i = 0; i < m; i++)
        if (a[i] != b[i]) return 0;
    return 1;
}

/* The fused step on up to STEP_MAX_THREADS threads. Every phase that works per individual
 * (the two rebuilds, the oscillation, the fitness) hands the individuals out one at a time;
 * ranking, the producers' best and the selection run on thread 0 between barriers. An
 * individual's work reads only its own random stream and the shared inputs of its phase, so
 * every result is the same, bit for bit, on any number of threads. What threads share: the
 * reachability memo (entries are single int64 stores, read and written with relaxed atomics;
 * a lost race only means an exact test is run again, so the count of exact tests, and only
 * that, can vary between runs with threads) and the fitness cache (thread t uses only its
 * share of the slots: slot mod nth = t). */
#define STEP_MAX_THREADS 8

#if HAVE_THREADS
static uint64_t now_ns(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (uint64_t)t.tv_sec * 1000000000ull + (uint64_t)t.tv_nsec;
}

/* A waiting thread spins this long before it sleeps: most waits at a barrier are a few
 * microseconds (the phases are tens to hundreds), but a thread whose CPU was taken away (a
 * loaded machine, a virtual machine's neighbours) can keep the others waiting far longer,
 * and a spinning CPU is then only wasted. */
#define BARRIER_SPIN_NS 50000

/* A counter threads wait on to change (a barrier's or the pool's generation), with what a
 * waiter that stopped spinning sleeps on. */
typedef struct {
    uint64_t gen;
    int sleepers; /* under mu */
    pthread_mutex_t mu;
    pthread_cond_t cv;
} Signal;

/* Waits until sig->gen differs from ``seen`` (spinning for spin_ns, then sleeping); the new
 * value. */
static uint64_t signal_wait(Signal *sig, uint64_t seen, uint64_t spin_ns) {
    uint64_t g, t0 = now_ns();
    unsigned spins = 0;
    while ((g = __atomic_load_n(&sig->gen, __ATOMIC_ACQUIRE)) == seen) {
        if (++spins % 64 != 0) continue;
        sched_yield();
        if (now_ns() - t0 <= spin_ns) continue;
        pthread_mutex_lock(&sig->mu);
        sig->sleepers++;
        while ((g = __atomic_load_n(&sig->gen, __ATOMIC_ACQUIRE)) == seen)
            pthread_cond_wait(&sig->cv, &sig->mu);
        sig->sleepers--;
        pthread_mutex_unlock(&sig->mu);
        break;
    }
    return g;
}

/* Bumps sig->gen and wakes its sleepers (a sleeper counted itself and read gen under the
 * lock: it sees the new value, or it is waiting and this wakes it). */
static void signal_bump(Signal *sig) {
    __atomic_add_fetch(&sig->gen, 1, __ATOMIC_ACQ_REL);
    pthread_mutex_lock(&sig->mu);
    if (sig->sleepers > 0) pthread_cond_broadcast(&sig->cv);
    pthread_mutex_unlock(&sig->mu);
}
#endif

typedef struct {
    int n, count;
#if HAVE_THREADS
    Signal done; /* bumped each time the last of the n arrives */
#endif
} Barrier;

/* A generation barrier: the last of n threads to arrive bumps the generation the others
 * wait on */
static void barrier_wait(Barrier *b) {
#if HAVE_THREADS
    if (b->n <= 1) return;
    uint64_t seen = __atomic_load_n(&b->done.gen, __ATOMIC_ACQUIRE); /* before arriving */
    if (__atomic_add_fetch(&b->count, 1, __ATOMIC_ACQ_REL) == b->n) {
        __atomic_store_n(&b->count, 0, __ATOMIC_RELAXED);
        signal_bump(&b->done);
    } else {
        signal_wait(&b->done, seen, BARRIER_SPIN_NS);
    }
#else
    (void)b;
#endif
}

struct Step;

/* The next unclaimed index of a parallel phase: threads take individuals one at a time, so
 * a thread that drew cheap individuals takes more of them (an individual's cost varies
 * severalfold: failed proposals, escapes, exact tests). */
static inline int64_t take_next(int64_t *next) {
#if HAVE_THREADS
    return __atomic_fetch_add(next, 1, __ATOMIC_RELAXED);
#else
    return (*next)++;
#endif
}

typedef struct {
    struct Step *s;
    int tid;
    Energy e;      /* this thread's energy scratch */
    ECache cache;  /* this thread's share of the fitness cache */
    ECache *cp;    /* &cache, or NULL without a cache */
    double *new_;  /* oscillation scratch (m) */
    int64_t n_chk, n_exact, evals, esc;
} StepLocal;

typedef struct Step {
    double *x, *f;
    unsigned char *fixed;
    const double *line, *goal_u, *pdraw, *signs;
    const int64_t *aware;
    const uint64_t *seeds1, *seeds2;
    int64_t G, n, m, n_prod, n_aw, iters, t_max, v_min, v_max, window, flags;
    double warn, st_value;
    const Reach *r;
    double *cand, *cand_s, *anchor, *spread, *first, *p_best, *f_prod, *fc;
    int64_t *order, *moved, *draw, *scr_idx, *near_row;
    unsigned char *active, *use_first, *escape, *ok_p, *ok_s, *fresh, *changed, *skip, *aware_of;
    int64_t best_i, worst_i, failed;
    int64_t next[2]; /* the parallel phases' next individual (or producer rank) to take */
    int nth;
    Barrier bar;
    StepLocal loc[STEP_MAX_THREADS];
} Step;

/* thread 0: ranking, then the producers' proposals (eq. 11 or SSA's eq. 3; the alarm case
 * P + Q·L) */
static void step_rank_and_propose(Step *s) {
    int64_t G = s->G, m = s->m, n_prod = s->n_prod, flags = s->flags;
    const double *x = s->x, *f = s->f, *line = s->line, *pdraw = s->pdraw;
    int64_t *order = s->order;
    /* order: a stable argsort of f (insertion sort; G is a population) */
    for (int64_t i = 0; i < G; i++) {
        int64_t k = i;
        while (k > 0 && f[order[k - 1]] > f[i]) {
            order[k] = order[k - 1];
            k--;
        }
        order[k] = i;
    }
    s->best_i = order[0];
    s->worst_i = order[G - 1];
    /* (the rebuild reads the proposal rows of active individuals only: those are set whole) */
    for (int64_t g = 0; g < G; g++) {
        s->draw[g] = DRAW_NONE;
        s->active[g] = 0;
        s->use_first[g] = 0;
        s->escape[g] = 0;
    }
    if (s->warn < s->st_value) {
        for (int64_t i = 0; i < n_prod; i++) {
            int64_t g = order[i];
            /* e = exp(−i/(α·M)), i the producer's rank, α = pdraw[i] */
            double ex = exp((double)(-(i + 1)) / (pdraw[i] * (double)s->iters));
            double *an = s->anchor + g * m, *sp = s->spread + g * m;
            const double *p = x + g * m;
            s->active[g] = 1;
            for (int64_t k = 0; k < m; k++) {
                double l = line[k];
                if (!(flags & SPSA_START_END)) {
                    an[k] = l + (p[k] - l) * ex; /* eq. 3 about the line, no random term */
                    sp[k] = 0.0;
                } else if (flags & SPSA_LITERAL) {
                    an[k] = p[k] + ex;
                    sp[k] = l - p[k];
                } else {
                    double d = p[k] - l;
                    an[k] = l + d * ex;
                    sp[k] = -d;
                }
            }
            if (flags & SPSA_START_END) s->draw[g] = DRAW_UNIFORM;
        }
        if (flags & SPSA_START_END) {
            /* the best producer: P + rand·(P_ST − P) */
            double *an = s->anchor + s->best_i * m, *sp = s->spread + s->best_i * m;
            const double *p = x + s->best_i * m;
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = line[k] - p[k];
            }
        }
    } else {
        for (int64_t i = 0; i < n_prod; i++) {
            int64_t g = order[i];
            double *an = s->anchor + g * m, *sp = s->spread + g * m, *fi = s->first + g * m;
            const double *p = x + g * m;
            s->active[g] = 1;
            s->draw[g] = DRAW_NORMAL;
            s->use_first[g] = 1;
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = 1.0;
                fi[k] = p[k] + pdraw[i];
            }
        }
    }
    /* everyone else cannot fail the first rebuild; their rows of cand are all written in
     * step_rest (every individual that is not a producer is a scrounger) */
    for (int64_t g = 0; g < G; g++) s->ok_p[g] = 1;
}

/* every thread: producers' rebuild and fitness, one producer at a time */
static void step_producers(Step *s, StepLocal *L) {
    int64_t m = s->m, i;
    while ((i = take_next(&s->next[0])) < s->n_prod) {
        int64_t g = s->order[i];
        rebuild_core(s->x, s->G, s->n, s->active, s->anchor, NULL, s->spread, s->draw, NULL,
                     NULL, (double[2]){INFINITY, INFINITY}, s->first, s->use_first, NULL, NULL,
                     s->escape, s->t_max, s->v_min, s->v_max, s->r, s->seeds1, s->cand, s->ok_p,
                     &L->n_chk, &L->n_exact, g, g + 1);
        s->fresh[g] = 1;
        if (same_path(s->cand + g * m, s->x + g * m, m)) {
            s->f_prod[g] = s->f[g];
        } else {
            s->f_prod[g] = energy_cached(s->cand + g * m, &L->e, L->cp, INFINITY);
            L->evals++;
        }
    }
}

/* thread 0: the producers' best; which individuals are scroungers (their eq. 4 index) and
 * danger-aware sparrows (their proposals are made by the threads, in step_propose_rest) */
static void step_roles(Step *s) {
    int64_t G = s->G, m = s->m, n_prod = s->n_prod, flags = s->flags;
    int64_t n_scr = G - n_prod;
    int64_t pb = -1;
    for (int64_t i = 0; i < n_prod; i++) {
        int64_t g = s->order[i];
        if (pb < 0 || s->f_prod[g] < s->f_prod[pb]) pb = g;
    }
    memcpy(s->p_best, s->cand + pb * m, sizeof(double) * m);
    for (int64_t i = n_prod; i < G; i++) s->fresh[s->order[i]] = 0;
    for (int64_t g = 0; g < G; g++) {
        s->scr_idx[g] = -1;
        s->near_row[g] = -1;
        s->aware_of[g] = 0;
    }
    int64_t i0 = (flags & SPSA_POP_INDEX) ? n_prod + 1 : 1;
    double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
    int64_t near_k = 0;
    for (int64_t k0 = 0; k0 < n_scr; k0++) {
        int64_t g = s->order[n_prod + k0];
        s->scr_idx[g] = i0 + k0;
        if (!((double)(i0 + k0) > half)) s->near_row[g] = near_k++;
    }
    for (int64_t i = 0; i < s->n_aw; i++) s->aware_of[s->aware[i]] = 1;
}

/* individual g's second proposal: a scrounger's (eq. 4, eq. 12's escape), then, for a
 * danger-aware sparrow, eq. 5's in its place; sets active, escape and draw for g */
static void step_propose_rest(Step *s, int64_t g) {
    int64_t G = s->G, n = s->n, m = s->m, flags = s->flags;
    int64_t n_scr = G - s->n_prod;
    const double *x = s->x, *f = s->f, *line = s->line;
    double *an = s->anchor + g * m, *sp = s->spread + g * m;
    const double *p = x + g * m;
    s->draw[g] = DRAW_NONE;
    s->active[g] = 0;
    s->escape[g] = 0;
    if (s->scr_idx[g] >= 0) {
        int64_t idx = s->scr_idx[g];
        double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
        s->active[g] = 1;
        s->escape[g] = (flags & SPSA_ESCAPE) ? 1 : 0;
        if ((double)idx > half) {
            /* i > n/2: Q·exp((P_worst − P)/i²) about the line */
            const double *xw = x + s->worst_i * m;
            double i2 = (double)idx * (double)idx;
            for (int64_t k = 0; k < m; k++) {
                double v = ((xw[k] - line[k]) - (p[k] - line[k])) / i2;
                an[k] = line[k];
                sp[k] = exp(v > 50.0 ? 50.0 : v);
            }
            s->draw[g] = DRAW_NORMAL;
        } else {
            /* P_p + |P − P_p|·A⁺·L: one offset per path */
            const double *sg = s->signs + s->near_row[g] * m;
            const double *pbest = s->p_best;
            double sy = 0.0, sz = 0.0;
            for (int64_t j = 0; j < n; j++) {
                sy += fabs(p[2 * j] - pbest[2 * j]) * sg[2 * j];
                sz += fabs(p[2 * j + 1] - pbest[2 * j + 1]) * sg[2 * j + 1];
            }
            sy = sy / (double)n;
            sz = sz / (double)n;
            for (int64_t j = 0; j < n; j++) {
                an[2 * j] = pbest[2 * j] + sy;
                an[2 * j + 1] = pbest[2 * j + 1] + sz;
                sp[2 * j] = 0.0;
                sp[2 * j + 1] = 0.0;
            }
        }
    }
    if (s->aware_of[g]) {
        s->active[g] = 1;
        s->escape[g] = 0;
        if (!(f[g] <= f[s->best_i])) {
            /* not the best: P_best + β·|P − P_best| */
            const double *xb = x + s->best_i * m;
            for (int64_t k = 0; k < m; k++) {
                an[k] = xb[k];
                sp[k] = fabs(p[k] - xb[k]);
            }
            s->draw[g] = DRAW_NORMAL;
        } else {
            /* the best: P + K·|P − P_worst|/(f_i − f_w + ε) */
            const double *xw = x + s->worst_i * m;
            double kk = 1.0 / (f[g] - f[s->worst_i] + SPSA_EPS);
            for (int64_t k = 0; k < m; k++) {
                an[k] = p[k];
                sp[k] = fabs(p[k] - xw[k]) * kk;
            }
            s->draw[g] = DRAW_SYMMETRIC;
        }
    }
}

/* every thread: its scroungers' and danger-aware sparrows' rebuild, the oscillation
 * optimisation (eq. 13) and the candidates' fitness */
static void step_rest(Step *s, StepLocal *L) {
    int64_t G = s->G, m = s->m, g;
    while ((g = take_next(&s->next[1])) < G) {
        step_propose_rest(s, g);
        /* (an inactive individual's row: copied from x, unchanged) */
        L->esc += rebuild_core(s->x, G, s->n, s->active, s->anchor, NULL, s->spread, s->draw,
                               NULL, NULL, (double[2]){INFINITY, INFINITY}, NULL, NULL, NULL,
                               NULL, s->escape, s->t_max, s->v_min, s->v_max, s->r, s->seeds2,
                               s->cand_s, s->ok_s, &L->n_chk, &L->n_exact, g, g + 1);
        if (s->active[g]) {
            memcpy(s->cand + g * m, s->cand_s + g * m, sizeof(double) * m);
            s->fresh[g] = 0;
        }
        s->changed[g] = !same_path(s->cand + g * m, s->x + g * m, m);
        if (s->flags & SPSA_OSCILLATE) {
            s->moved[g] = 0;
            s->skip[g] = !s->changed[g] && s->fixed[g]; /* a known fixed point of eq. 13 */
            mar_core(s->cand, G, s->n, s->goal_u, s->window, s->r, s->skip, s->moved, L->new_,
                     &L->n_chk, &L->n_exact, g, g + 1);
            if (!s->changed[g] && !s->skip[g]) s->fixed[g] = s->moved[g] == 0;
            if (s->moved[g] > 0) {
                s->fresh[g] = 0;
                s->changed[g] = !same_path(s->cand + g * m, s->x + g * m, m);
            }
        }
        if (!s->changed[g]) continue;
        if (s->fresh[g]) {
            s->fc[g] = s->f_prod[g]; /* a producer's candidate evaluated above, not moved since */
        } else {
            s->fc[g] = energy_cached(s->cand + g * m, &L->e, L->cp, s->f[g]);
            L->evals++;
        }
    }
}

/* thread 0: greedy selection */
static void step_select(Step *s) {
    int64_t m = s->m;
    int64_t failed = 0;
    for (int64_t g = 0; g < s->G; g++) {
        failed += !s->ok_p[g] + !s->ok_s[g];
        if (!s->changed[g]) continue;
        if (s->fc[g] < s->f[g]) {
            memcpy(s->x + g * m, s->cand + g * m, sizeof(double) * m);
            s->f[g] = s->fc[g];
            if (s->flags & SPSA_OSCILLATE) s->fixed[g] = 0;
        }
    }
    s->failed = failed;
}

static void step_run(StepLocal *L) {
    Step *s = L->s;
    if (L->tid == 0) step_rank_and_propose(s);
    barrier_wait(&s->bar);
    step_producers(s, L);
    barrier_wait(&s->bar);
    if (L->tid == 0) step_roles(s);
    barrier_wait(&s->bar);
    step_rest(s, L);
    barrier_wait(&s->bar);
    if (L->tid == 0) step_select(s);
}

#if HAVE_THREADS
/* The step's helper threads live in a process-wide pool, started on first use and parked
 * between steps: starting a thread costs 50-70 microseconds here, a tenth of a step. A
 * helper waits for the next step spinning for 0.2 ms (the Python code between two steps
 * takes about 0.1 ms), then sleeps on a condition variable. One step uses the
 * pool at a time: a step that finds it busy (another Python thread is planning) runs on its
 * caller's thread alone, with the same results. After fork() the child has no helpers: the
 * pool starts again. */
#define POOL_SPIN_NS 200000

typedef struct {
    Signal step;  /* its generation is bumped for each step */
    int started;  /* helpers running (tids 1 .. started) */
    int busy;     /* a step holds the pool */
    Step *job;    /* the current step */
    int finished; /* helpers done with the current step */
    int atfork;   /* the fork handler is registered */
} Pool;

static Pool pool = {{0, 0, PTHREAD_MUTEX_INITIALIZER, PTHREAD_COND_INITIALIZER}, 0, 0, NULL, 0, 0};
/* the generation each helper was started at: it waits for the one after (a helper that read
 * pool.gen itself might read it after the step that started it had bumped it, and wait for
 * a step that never comes) */
static uint64_t pool_start_gen[STEP_MAX_THREADS];

static void pool_atfork_child(void) {
    pthread_mutex_init(&pool.step.mu, NULL);
    pthread_cond_init(&pool.step.cv, NULL);
    pool.step.sleepers = 0;
    pool.started = 0;
    pool.busy = 0;
    pool.job = NULL;
    pool.finished = 0;
}

static void *pool_helper(void *arg) {
    int tid = (int)(intptr_t)arg;
    uint64_t seen = pool_start_gen[tid];
    for (;;) {
        seen = signal_wait(&pool.step, seen, POOL_SPIN_NS);
        Step *s = __atomic_load_n(&pool.job, __ATOMIC_ACQUIRE);
        if (s != NULL && tid < s->nth) step_run(&s->loc[tid]);
        __atomic_add_fetch(&pool.finished, 1, __ATOMIC_ACQ_REL);
    }
    return NULL;
}

/* Holds the pool for one step with at least want − 1 helpers running; the helpers available
 * (0 when the pool is busy or no thread could be started). */
static int pool_acquire(int want) {
    int expected = 0;
    if (!__atomic_compare_exchange_n(&pool.busy, &expected, 1, 0, __ATOMIC_ACQUIRE,
                                     __ATOMIC_RELAXED))
        return 0;
    if (!pool.atfork) {
        pthread_atfork(NULL, NULL, pool_atfork_child);
        pool.atfork = 1;
    }
    while (pool.started < want - 1 && pool.started < STEP_MAX_THREADS - 1) {
        pthread_t th;
        pthread_attr_t attr;
        pthread_attr_init(&attr);
        pthread_attr_setdetachstate(&attr, PTHREAD_CREATE_DETACHED);
        pool_start_gen[pool.started + 1] = __atomic_load_n(&pool.step.gen, __ATOMIC_ACQUIRE);
        int rc = pthread_create(&th, &attr, pool_helper, (void *)(intptr_t)(pool.started + 1));
        pthread_attr_destroy(&attr);
        if (rc != 0) break;
        pool.started++;
    }
    return pool.started;
}
#endif

/* Runs the step on s->nth threads: the caller's and nth − 1 of the pool's helpers (fewer if
 * the pool is busy or the system refuses a thread: the results are the same). Helpers beyond
 * nth − 1 wake, find nothing to do and count themselves finished. */
static void step_parallel(Step *s) {
#if HAVE_THREADS
    if (s->nth > 1) {
        int helpers = pool_acquire(s->nth);
        if (helpers > 0) {
            if (s->nth > helpers + 1) s->nth = helpers + 1;
            s->bar.n = s->nth;
            pthread_mutex_init(&s->bar.done.mu, NULL);
            pthread_cond_init(&s->bar.done.cv, NULL);
            __atomic_store_n(&pool.finished, 0, __ATOMIC_RELAXED);
            __atomic_store_n(&pool.job, s, __ATOMIC_RELEASE);
            signal_bump(&pool.step);
            step_run(&s->loc[0]);
            unsigned spins = 0;
            while (__atomic_load_n(&pool.finished, __ATOMIC_ACQUIRE) < helpers)
                if (++spins % 64 == 0) sched_yield();
            __atomic_store_n(&pool.job, NULL, __ATOMIC_RELEASE);
            __atomic_store_n(&pool.busy, 0, __ATOMIC_RELEASE);
            pthread_cond_destroy(&s->bar.done.cv);
            pthread_mutex_destroy(&s->bar.done.mu);
            return;
        }
    }
#endif
    s->nth = 1;
    s->bar.n = 1;
    step_run(&s->loc[0]);
}

/* spsa_step(x, f, osc_fixed, line, goal_u, reach, energy, n_prod, iterations, t_max, v_min,
 *           v_max, window, flags, warn, warning_value, pdraw, signs, aware, seeds1, seeds2,
 *           counts, cache, threads)
 *
 * One iteration of SparrowPlanner.step, in place on x (G, n, 2), f (G,) and osc_fixed (G,):
 * producers (eq. 11 or eq. 3), their rebuild under the reachability rule and fitness, then
 * scroungers (eq. 4 with eq. 12's escape) and danger-aware sparrows (eq. 5), their rebuild,
 * the oscillation optimisation (eq. 13) and greedy selection. The random numbers numpy's
 * Generator draws for the step arrive drawn (``warn``: R2; ``pdraw`` (n_prod,): α = 1 − U
 * when R2 < ST else Q ~ N(0, 1); ``signs`` (near, n, 2): eq. 4's ±1; ``aware``: the
 * danger-aware sparrows; ``seeds1`` / ``seeds2`` (G,): the two rebuilds' streams), so the
 * step is the same function of the Generator as the numpy formulation in the tests
 * (tests/spsa_reference.py). ``counts`` (3,) int64 gets += (evaluations, escapes, failed
 * updates). */
static PyObject *py_spsa_step(PyObject *self, PyObject *args) {
    PyObject *ox, *of, *ofix, *oline, *ogoal, *ro, *oen, *opd, *osg, *oaw, *os1, *os2, *ocnt;
    PyObject *ocache;
    long long n_prod, iters, t_max, v_min, v_max, window, flags, threads;
    double warn, st_value;
    Buf bx = {0}, bf = {0}, bfix = {0}, bline = {0}, bgoal = {0}, bpd = {0}, bsg = {0},
        baw = {0}, bs1 = {0}, bs2 = {0}, bcnt = {0}, ben[3], bc[3];
    Energy e;
    ECache cache = {0}, *cp = NULL;
    Reach r;
    ReachBufs rb;
    double *mem = NULL;
    memset(ben, 0, sizeof(ben));
    memset(bc, 0, sizeof(bc));
    memset(&e, 0, sizeof(e));
    if (!PyArg_ParseTuple(args, "OOOOOOOLLLLLLLddOOOOOOOL", &ox, &of, &ofix, &oline, &ogoal,
                          &ro, &oen, &n_prod, &iters, &t_max, &v_min, &v_max, &window, &flags,
                          &warn, &st_value, &opd, &osg, &oaw, &os1, &os2, &ocnt, &ocache,
                          &threads))
        return NULL;
    if (reach_get(ro, &r, &rb) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(ox, &bx, T_F64, 3, 1, "x") < 0 || get_buf(of, &bf, T_F64, 1, 1, "f") < 0 ||
        get_buf(ofix, &bfix, T_BOOL, 1, 1, "osc_fixed") < 0 ||
        get_buf(oline, &bline, T_F64, 2, 0, "line") < 0 ||
        get_buf(ogoal, &bgoal, T_F64, 1, 0, "goal_u") < 0 ||
        get_buf(opd, &bpd, T_F64, 1, 0, "pdraw") < 0 ||
        get_buf(osg, &bsg, T_F64, 3, 0, "signs") < 0 ||
        get_buf(oaw, &baw, T_I64, 1, 0, "aware") < 0 ||
        get_buf(os1, &bs1, T_U64, 1, 0, "seeds1") < 0 ||
        get_buf(os2, &bs2, T_U64, 1, 0, "seeds2") < 0 ||
        get_buf(ocnt, &bcnt, T_I64, 1, 1, "counts") < 0)
        goto done;
    int64_t G = dim(&bx, 0), n = dim(&bx, 1);
    int64_t m = 2 * n;
    int64_t n_scr = G - n_prod;
    int64_t n_aw = dim(&baw, 0);
    if (need(dim(&bx, 2) == 2 && n >= 1 && n <= r.ncols - 2 && dim(&bf, 0) == G &&
                 dim(&bfix, 0) == G && dim(&bline, 0) == n && dim(&bline, 1) == 2 &&
                 dim(&bgoal, 0) >= 2 && 1 <= n_prod && n_prod < G && dim(&bpd, 0) == n_prod &&
                 dim(&bs1, 0) == G && dim(&bs2, 0) == G && dim(&bcnt, 0) == 3 && n_aw <= G &&
                 iters >= 1 && t_max >= 1 && window >= 3 && 1 <= v_min && v_min <= v_max &&
                 (dim(&bsg, 0) == 0 || (dim(&bsg, 1) == n && dim(&bsg, 2) == 2)),
             "spsa_step: inconsistent arguments") < 0)
        goto done;
    {
        const int64_t *aw = I64(baw);
        for (int64_t i = 0; i < n_aw; i++)
            if (need(0 <= aw[i] && aw[i] < G, "spsa_step: aware index out of range") < 0)
                goto done;
    }
    {
        /* eq. 4's near scroungers (rank i <= n/2): one row of signs each */
        int64_t i0 = (flags & SPSA_POP_INDEX) ? n_prod + 1 : 1;
        double half = (flags & SPSA_POP_INDEX) ? (double)G / 2.0 : (double)n_scr / 2.0;
        int64_t near = 0;
        for (int64_t s = 0; s < n_scr; s++) near += (double)(i0 + s) <= half;
        if (need(near == dim(&bsg, 0), "spsa_step: signs: one row per near scrounger") < 0)
            goto done;
    }
    if (energy_get(oen, &e, ben, n) < 0) goto done;
    if (ocache != Py_None) {
        PyObject *of_, *ov_, *op_;
        if (!PyArg_ParseTuple(ocache, "OOO", &of_, &ov_, &op_)) goto done;
        if (get_buf(of_, &bc[0], T_BOOL, 1, 1, "cache.filled") < 0 ||
            get_buf(ov_, &bc[1], T_F64, 1, 1, "cache.values") < 0 ||
            get_buf(op_, &bc[2], T_I32, 2, 1, "cache.paths") < 0)
            goto done;
        cache.slots = dim(&bc[0], 0);
        cache.m = m;
        if (need(dim(&bc[1], 0) == cache.slots && dim(&bc[2], 0) == cache.slots &&
                     dim(&bc[2], 1) == m && (cache.slots & (cache.slots - 1)) == 0,
                 "spsa_step: cache: (slots,) flags and values, (slots, 2n) paths, slots a power "
                 "of two") < 0)
            goto done;
        cache.filled = BOOL(bc[0]);
        cache.vals = F64(bc[1]);
        cache.paths = (int32_t *)bc[2].view.buf;
        cp = &cache;
    }
    /* scratch: cand, cand_s, anchor, spread, first (G·m each), p_best (m), new_ (m per
     * thread), f_prod, fc (G each); int64 order, moved, draw, scr_idx, near_row (G each); 9
     * byte flags (G each) */
    int nth = threads < 1 ? 1 : threads > STEP_MAX_THREADS ? STEP_MAX_THREADS : (int)threads;
    if (nth > G) nth = (int)G;
    if (!HAVE_THREADS) nth = 1;
    size_t nd = (size_t)(5 * G * m + m + (int64_t)nth * m + 2 * G);
    mem = malloc(sizeof(double) * nd + sizeof(int64_t) * 5 * (size_t)G + 9 * (size_t)G);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    Step st = {.x = F64(bx), .f = F64(bf), .fixed = BOOL(bfix), .line = F64(bline),
               .goal_u = F64(bgoal), .pdraw = F64(bpd), .signs = F64(bsg), .aware = I64(baw),
               .seeds1 = U64(bs1), .seeds2 = U64(bs2), .G = G, .n = n, .m = m,
               .n_prod = n_prod, .n_aw = n_aw, .iters = iters, .t_max = t_max,
               .v_min = v_min, .v_max = v_max, .window = window, .flags = flags, .warn = warn,
               .st_value = st_value, .r = &r}; /* the rest zero */
    st.cand = mem;
    st.cand_s = st.cand + G * m;
    st.anchor = st.cand_s + G * m;
    st.spread = st.anchor + G * m;
    st.first = st.spread + G * m;
    st.p_best = st.first + G * m;
    double *news = st.p_best + m;
    st.f_prod = news + (int64_t)nth * m;
    st.fc = st.f_prod + G;
    st.order = (int64_t *)(st.fc + G);
    st.moved = st.order + G;
    st.draw = st.moved + G;
    st.scr_idx = st.draw + G;
    st.near_row = st.scr_idx + G;
    st.active = (unsigned char *)(st.near_row + G);
    st.use_first = st.active + G;
    st.escape = st.use_first + G;
    st.ok_p = st.escape + G;
    st.ok_s = st.ok_p + G;
    st.fresh = st.ok_s + G;
    st.changed = st.fresh + G;
    st.skip = st.changed + G;
    st.aware_of = st.skip + G;
    /* per thread: energy scratch, a share of the fitness cache, oscillation scratch */
    for (int t = 0; t < nth; t++) {
        StepLocal *L = &st.loc[t];
        L->s = &st;
        L->tid = t;
        L->new_ = news + (int64_t)t * m;
        L->e = e;
        if (t > 0) {
            L->e.work = NULL;
            if (energy_init(&L->e) < 0) {
                for (int u = 1; u < t; u++) free(st.loc[u].e.work);
                goto done;
            }
        }
        if (cp != NULL) {
            L->cache = cache;
            L->cache.part = t;
            L->cache.nparts = nth;
            L->cp = &L->cache;
        }
    }
    st.nth = nth;
    /* From here to the counts, plain C on the buffers acquired above: other Python threads
     * run meanwhile (the CLI imports the mission writer's libraries during the search). */
    PyThreadState *ts = PyEval_SaveThread();
    step_parallel(&st);
    int64_t n_chk = 0, n_exact = 0, evals = 0, esc = 0;
    for (int t = 0; t < nth; t++) {
        n_chk += st.loc[t].n_chk;
        n_exact += st.loc[t].n_exact;
        evals += st.loc[t].evals;
        esc += st.loc[t].esc;
        if (t > 0) free(st.loc[t].e.work);
    }
    r.counts[0] += n_chk;
    r.counts[1] += n_exact;
    int64_t *counts = I64(bcnt);
    counts[0] += evals;
    counts[1] += esc;
    counts[2] += st.failed;
    PyEval_RestoreThread(ts);
    ret = Py_NewRef(Py_None);
done:
    free(mem);
    free(e.work);
    for (int i = 0; i < 3; i++) rel(&ben[i]);
    for (int i = 0; i < 3; i++) rel(&bc[i]);
    rel(&bx);
    rel(&bf);
    rel(&bfix);
    rel(&bline);
    rel(&bgoal);
    rel(&bpd);
    rel(&bsg);
    rel(&baw);
    rel(&bs1);
    rel(&bs2);
    rel(&bcnt);
    reach_release(&rb);
    return ret;
}

/* ------------------------------------------------------------------------------------------
 * Grid A* (uavplan/planners/astar.py)
 */

enum { A_FOUND = 0, A_NO_PATH = 1, A_INVALID_START = 2, A_INVALID_GOAL = 3 };

static double node_clearance(double px, double py, double pz, const World *w, double cap) {
    double eps = 1e-9;
    if (pz < w->zlim[0] - eps || pz > w->zlim[1] + eps) return -1.0;
    for (Py_ssize_t i = 0; i < w->nhp; i++) {
        const double *h = w->hp + 3 * i;
        if (h[0] * px + h[1] * py > h[2] + eps) return -1.0;
    }
    double best = cap;
    for (int64_t k = 0; k < w->npieces; k++) {
        const double *bk = w->box + 5 * k;
        double gx = dmax(dmax(0.0, bk[0] - px), px - bk[1]);
        double gy = dmax(dmax(0.0, bk[2] - py), py - bk[3]);
        double gz = dmax(dmax(0.0, pz - bk[4]), -pz);
        if (k < w->npoly && w->poly_h[k] < 0.0) gz = dmax(gz, -w->poly_h[k] - pz);
        if (gx * gx + gy * gy + gz * gz >= best * best) continue;
        double d = point_piece_dist(px, py, pz, k, w);
        if (d < best) best = d;
    }
    return best;
}

static PyObject *py_node_clearance(PyObject *self, PyObject *args) {
    double px, py, pz, cap;
    PyObject *wt;
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "dddOd", &px, &py, &pz, &wt, &cap)) return NULL;
    if (world_get(wt, &wb, 7) < 0) return NULL;
    double r = node_clearance(px, py, pz, &wb.w, cap);
    world_release(&wb);
    return PyFloat_FromDouble(r);
}

static inline int before(int64_t a, int64_t b, const double *f, const double *h) {
    if (f[a] != f[b]) return f[a] < f[b];
    return h[a] < h[b];
}

static void sift_up(int64_t *heap, int64_t *pos, int64_t i, const double *f, const double *h) {
    int64_t v = heap[i];
    while (i > 0) {
        int64_t p = (i - 1) >> 1;
        if (!before(v, heap[p], f, h)) break;
        heap[i] = heap[p];
        pos[heap[i]] = i;
        i = p;
    }
    heap[i] = v;
    pos[v] = i;
}

static int64_t heap_pop(int64_t *heap, int64_t *pos, int64_t size, const double *f,
                        const double *h) {
    int64_t top = heap[0];
    pos[top] = -1;
    size -= 1;
    if (size > 0) {
        int64_t v = heap[size];
        int64_t i = 0;
        for (;;) {
            int64_t c = 2 * i + 1;
            if (c >= size) break;
            if (c + 1 < size && before(heap[c + 1], heap[c], f, h)) c += 1;
            if (!before(heap[c], v, f, h)) break;
            heap[i] = heap[c];
            pos[heap[i]] = i;
            i = c;
        }
        heap[i] = v;
        pos[v] = i;
    }
    return top;
}

static int64_t links(double px, double py, double pz, double radius, const int64_t *lo,
                     const int64_t *shape, const double *steps, const World *w, double margin,
                     double cap, double *clear, int64_t *out_node, double *out_cost,
                     int64_t out_cap, double k0, double k2) {
    double lim = dmax(margin - 1e-9, 1e-9);
    int64_t ny = shape[1];
    int64_t nz = shape[2];
    double u[3] = {px / steps[0], py / steps[1], pz / steps[2]};
    int64_t rlo[3], rhi[3];
    for (int ax = 0; ax < 3; ax++) {
        rlo[ax] = imax((int64_t)ceil(u[ax] - radius - 1e-9) - lo[ax], 0);
        rhi[ax] = imin((int64_t)floor(u[ax] + radius + 1e-9) - lo[ax], shape[ax] - 1);
    }
    int64_t n = 0;
    for (int64_t a = rlo[0]; a < rhi[0] + 1; a++) {
        double x = (double)(a + lo[0]) * steps[0];
        for (int64_t b = rlo[1]; b < rhi[1] + 1; b++) {
            double y = (double)(b + lo[1]) * steps[1];
            for (int64_t c = rlo[2]; c < rhi[2] + 1; c++) {
                double z = (double)(c + lo[2]) * steps[2];
                int64_t v = (a * ny + b) * nz + c;
                if (isnan(clear[v])) clear[v] = node_clearance(x, y, z, w, cap);
                if (clear[v] < lim) continue;
                if (!segment_free(px, py, pz, x, y, z, w, margin)) continue;
                if (n < out_cap) {
                    double ex = x - px;
                    double ey = y - py;
                    double ez = z - pz;
                    out_node[n] = v;
                    out_cost[n] = k0 * sqrt(ex * ex + ey * ey + ez * ez) + k2 * fabs(ez);
                    n += 1;
                }
            }
        }
    }
    return n;
}

/* astar_kernel(lo, shape, steps, start, goal, W, margin, cap, k0, k2, moves)
 *   -> (status, path bytes (k, 3) float64, expanded, cost) */
static PyObject *py_astar_kernel(PyObject *self, PyObject *args) {
    PyObject *olo, *osh, *ost, *os, *og, *wt, *om;
    double margin, cap, k0, k2;
    Buf blo = {0}, bsh = {0}, bst = {0}, bs = {0}, bgl = {0}, bm = {0};
    WorldBufs wb;
    static const double LINK_RADII[3] = {1.0, 2.0, 3.0};
    if (!PyArg_ParseTuple(args, "OOOOOOddddO", &olo, &osh, &ost, &os, &og, &wt, &margin, &cap,
                          &k0, &k2, &om))
        return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    void *mem = NULL;
    if (get_buf(olo, &blo, T_I64, 1, 0, "lo") < 0 || get_buf(osh, &bsh, T_I64, 1, 0, "shape") < 0 ||
        get_buf(ost, &bst, T_F64, 1, 0, "steps") < 0 || get_buf(os, &bs, T_F64, 1, 0, "start") < 0 ||
        get_buf(og, &bgl, T_F64, 1, 0, "goal") < 0 || get_buf(om, &bm, T_I64, 2, 0, "moves") < 0)
        goto done;
    if (need(dim(&blo, 0) == 3 && dim(&bsh, 0) == 3 && dim(&bst, 0) == 3 && dim(&bs, 0) == 3 &&
                 dim(&bgl, 0) == 3 && dim(&bm, 1) == 3 && I64(bsh)[0] >= 1 && I64(bsh)[1] >= 1 &&
                 I64(bsh)[2] >= 1,
             "astar: inconsistent shapes") < 0)
        goto done;
    const int64_t *lo = I64(blo), *shape = I64(bsh), *moves = I64(bm);
    const double *steps = F64(bst), *start = F64(bs), *goal = F64(bgl);
    const World *w = &wb.w;
    int64_t nj = shape[0], ny = shape[1], nz = shape[2];
    int64_t n_nodes = nj * ny * nz;
    int64_t goal_id = n_nodes;
    int64_t start_id = n_nodes + 1;
    double lim = dmax(margin - 1e-9, 1e-9);
    double dx = steps[0], dy = steps[1], dz = steps[2];
    int64_t n_moves = dim(&bm, 0);
    size_t nn = (size_t)n_nodes + 1;
    /* one block: clear (n), g, f, h (n + 1), goal_link (n), parent, heap, pos (n + 1),
     * closed (n + 1 bytes) */
    mem = malloc(sizeof(double) * (2 * (size_t)n_nodes + 3 * nn) + sizeof(int64_t) * 3 * nn +
                 nn);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *clear = mem;
    double *g = clear + n_nodes;
    double *f = g + nn;
    double *h = f + nn;
    double *goal_link = h + nn;
    int64_t *parent = (int64_t *)(goal_link + n_nodes);
    int64_t *heap = parent + nn;
    int64_t *pos = heap + nn;
    unsigned char *closed = (unsigned char *)(pos + nn);
    for (int64_t i = 0; i < n_nodes; i++) {
        clear[i] = NAN;
        goal_link[i] = INFINITY;
    }
    for (size_t i = 0; i < nn; i++) {
        g[i] = INFINITY;
        f[i] = INFINITY;
        h[i] = 0.0;
        parent[i] = -1;
        closed[i] = 0;
        pos[i] = -1;
    }
    int64_t size = 0;
    double gx = goal[0], gy = goal[1], gz = goal[2];
    int64_t buf_node[343];
    double buf_cost[343];
    int64_t n_goal = 0;
    for (int ri = 0; ri < 3; ri++) {
        n_goal = links(gx, gy, gz, LINK_RADII[ri], lo, shape, steps, w, margin, cap, clear,
                       buf_node, buf_cost, 343, k0, k2);
        if (n_goal > 0) break;
    }
    for (int64_t i = 0; i < n_goal; i++) goal_link[buf_node[i]] = buf_cost[i];
    if (n_goal == 0) {
        ret = Py_BuildValue("(iy#Ld)", A_INVALID_GOAL, "", (Py_ssize_t)0, 0LL, INFINITY);
        goto done;
    }
    int64_t n_start = 0;
    for (int ri = 0; ri < 3; ri++) {
        n_start = links(start[0], start[1], start[2], LINK_RADII[ri], lo, shape, steps, w, margin,
                        cap, clear, buf_node, buf_cost, 343, k0, k2);
        if (n_start > 0) break;
    }
    if (n_start == 0) {
        ret = Py_BuildValue("(iy#Ld)", A_INVALID_START, "", (Py_ssize_t)0, 0LL, INFINITY);
        goto done;
    }
    for (int64_t i = 0; i < n_start; i++) {
        int64_t v = buf_node[i];
        int64_t c = v % nz;
        int64_t b = (v / nz) % ny;
        int64_t a = v / (ny * nz);
        double ex = (double)(a + lo[0]) * dx - gx;
        double ey = (double)(b + lo[1]) * dy - gy;
        double ez = (double)(c + lo[2]) * dz - gz;
        g[v] = buf_cost[i];
        h[v] = k0 * sqrt(ex * ex + ey * ey + ez * ez) + k2 * fabs(ez);
        f[v] = g[v] + h[v];
        parent[v] = start_id;
        heap[size] = v;
        size += 1;
        sift_up(heap, pos, size - 1, f, h);
    }
    double mxv[64], myv[64], mzv[64], mcost[64], mlen[64];
    if (need(n_moves <= 64, "astar: at most 64 moves") < 0) goto done;
    for (int64_t m = 0; m < n_moves; m++) {
        mxv[m] = (double)moves[3 * m] * dx;
        myv[m] = (double)moves[3 * m + 1] * dy;
        mzv[m] = (double)moves[3 * m + 2] * dz;
        mlen[m] = sqrt(mxv[m] * mxv[m] + myv[m] * myv[m] + mzv[m] * mzv[m]);
        mcost[m] = k0 * mlen[m] + k2 * fabs(mzv[m]);
    }
    int64_t expanded = 0;
    int found = 0;
    while (size > 0) {
        int64_t u = heap_pop(heap, pos, size, f, h);
        size -= 1;
        if (u == goal_id) {
            found = 1;
            break;
        }
        closed[u] = 1;
        expanded += 1;
        if (goal_link[u] < INFINITY && g[u] + goal_link[u] < g[goal_id]) {
            g[goal_id] = g[u] + goal_link[u];
            f[goal_id] = g[goal_id];
            parent[goal_id] = u;
            if (pos[goal_id] < 0) {
                heap[size] = goal_id;
                pos[goal_id] = size;
                size += 1;
            }
            sift_up(heap, pos, pos[goal_id], f, h);
        }
        int64_t c = u % nz;
        int64_t b = (u / nz) % ny;
        int64_t a = u / (ny * nz);
        double ux = (double)(a + lo[0]) * dx;
        double uy = (double)(b + lo[1]) * dy;
        double uz = (double)(c + lo[2]) * dz;
        double du = clear[u];
        for (int64_t m = 0; m < n_moves; m++) {
            int64_t a2 = a + moves[3 * m];
            int64_t b2 = b + moves[3 * m + 1];
            int64_t c2 = c + moves[3 * m + 2];
            if (a2 < 0 || a2 >= nj || b2 < 0 || b2 >= ny || c2 < 0 || c2 >= nz) continue;
            int64_t v = (a2 * ny + b2) * nz + c2;
            if (closed[v]) continue;
            double ng = g[u] + mcost[m];
            if (ng >= g[v]) continue;
            double vx = ux + mxv[m];
            double vy = uy + myv[m];
            double vz = uz + mzv[m];
            double dv = clear[v];
            if (isnan(dv)) {
                dv = node_clearance(vx, vy, vz, w, cap);
                clear[v] = dv;
            }
            if (dv < lim) {
                closed[v] = 2;
                continue;
            }
            if (du + dv - mlen[m] < 2.0 * lim) {
                if (!segment_free(ux, uy, uz, vx, vy, vz, w, margin)) continue;
            }
            g[v] = ng;
            parent[v] = u;
            if (pos[v] < 0) {
                double ex = vx - gx;
                double ey = vy - gy;
                double ez = vz - gz;
                h[v] = k0 * sqrt(ex * ex + ey * ey + ez * ez) + k2 * fabs(ez);
                f[v] = ng + h[v];
                heap[size] = v;
                size += 1;
                sift_up(heap, pos, size - 1, f, h);
            } else {
                f[v] = ng + h[v];
                sift_up(heap, pos, pos[v], f, h);
            }
        }
    }
    if (!found) {
        ret = Py_BuildValue("(iy#Ld)", A_NO_PATH, "", (Py_ssize_t)0, (long long)expanded,
                            INFINITY);
        goto done;
    }
    int64_t count = 0;
    int64_t v = parent[goal_id];
    while (v != start_id) {
        count += 1;
        v = parent[v];
    }
    PyObject *path = PyBytes_FromStringAndSize(NULL, (Py_ssize_t)(count * 3 * sizeof(double)));
    if (path == NULL) goto done;
    double *nodes = (double *)PyBytes_AS_STRING(path);
    v = parent[goal_id];
    for (int64_t i = count - 1; i > -1; i--) {
        nodes[3 * i] = (double)(v / (ny * nz) + lo[0]) * dx;
        nodes[3 * i + 1] = (double)((v / nz) % ny + lo[1]) * dy;
        nodes[3 * i + 2] = (double)(v % nz + lo[2]) * dz;
        v = parent[v];
    }
    ret = Py_BuildValue("(iNLd)", A_FOUND, path, (long long)expanded, g[goal_id]);
done:
    free(mem);
    rel(&blo);
    rel(&bsh);
    rel(&bst);
    rel(&bs);
    rel(&bgl);
    rel(&bm);
    world_release(&wb);
    return ret;
}

/* ------------------------------------------------------------------------------------------
 * Module
 */

static PyMethodDef methods[] = {
    {"point_polygon_dist2d", py_point_polygon_dist2d, METH_VARARGS, NULL},
    {"point_piece_dist", py_point_piece_dist, METH_VARARGS, NULL},
    {"seg_piece_dist", py_seg_piece_dist, METH_VARARGS, NULL},
    {"segment_free", py_segment_free, METH_VARARGS, NULL},
    {"segments_free", py_segments_free, METH_VARARGS, NULL},
    {"farthest_visible", py_farthest_visible, METH_VARARGS, NULL},
    {"refine_vertices", py_refine_vertices, METH_VARARGS, NULL},
    {"points_clearance", py_points_clearance, METH_VARARGS, NULL},
    {"segments_clearance", py_segments_clearance, METH_VARARGS, NULL},
    {"cells_count", py_cells_count, METH_VARARGS, NULL},
    {"cells_fill", py_cells_fill, METH_VARARGS, NULL},
    {"node_status", py_node_status, METH_VARARGS, NULL},
    {"node_resolve", py_node_resolve, METH_VARARGS, NULL},
    {"reachable", py_reachable, METH_VARARGS, NULL},
    {"clearance_table", py_clearance_table, METH_VARARGS, NULL},
    {"init_population", py_init_population, METH_VARARGS, NULL},
    {"rebuild", py_rebuild, METH_VARARGS, NULL},
    {"moving_average_repair", py_moving_average_repair, METH_VARARGS, NULL},
    {"paths_feasible", py_paths_feasible, METH_VARARGS, NULL},
    {"ziggurat_tables", py_ziggurat_tables, METH_NOARGS, NULL},
    {"stream_draws", py_stream_draws, METH_VARARGS, NULL},
    {"polyline_energy", py_polyline_energy, METH_VARARGS, NULL},
    {"spline_points", py_spline_points, METH_VARARGS, NULL},
    {"population_energy", py_population_energy, METH_VARARGS, NULL},
    {"largest_free_fraction", py_largest_free_fraction, METH_VARARGS, NULL},
    {"round_grid", py_round_grid, METH_VARARGS, NULL},
    {"energy_bounds", py_energy_bounds, METH_VARARGS, NULL},
    {"spsa_step", py_spsa_step, METH_VARARGS, NULL},
    {"sign_draws", py_sign_draws, METH_VARARGS, NULL},
    {"node_clearance", py_node_clearance, METH_VARARGS, NULL},
    {"astar_kernel", py_astar_kernel, METH_VARARGS, NULL},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moddef = {
    PyModuleDef_HEAD_INIT, "_ckernels",
    "Compiled kernels of uavplan (C; see uavplan/_ckernels.c).", -1, methods, NULL, NULL, NULL,
    NULL,
};

PyMODINIT_FUNC PyInit__ckernels(void) {
    ziggurat_init();
    return PyModule_Create(&moddef);
}
