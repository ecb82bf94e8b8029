/* uavplan._ckernels: distances from points and segments to the world's convex pieces, the
 * uniform cell grid over them, segment tests, clearance queries, and the vertex refinement
 * of uavplan/path/post.py. Knows nothing of planners. */
#include "kernels.h"

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

static double py_hypot(double x, double y) {
    /* numba's math.hypot: inf if either is infinite, else the C library's hypot */
    if (isinf(x) || isinf(y)) return INFINITY;
    return hypot(x, y);
}

double point_piece_dist(double px, double py, double pz, int64_t k, const World *w) {
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

/* The rows [*lo, *hi] of grid column ``cx`` (clipped to [cy0, cy1]) whose cells can hold a
 * point within ``m`` of the segment's plan view a→b: the segment's points whose x lies within
 * ``m`` of the column give its y range, grown by ``m`` (a point within m of the segment is
 * within m of one of them in x and in y). Empty when *lo > *hi. */
static inline void corridor_rows(double ax, double ay, double bx, double by, double m, int64_t cx,
                                 double gx0, double gy0, double cell, int64_t ny, int64_t cy0,
                                 int64_t cy1, int64_t *lo, int64_t *hi) {
    double x0 = gx0 + (double)cx * cell - m;
    double x1 = gx0 + (double)(cx + 1) * cell + m;
    double dx = bx - ax;
    double t0 = 0.0, t1 = 1.0;
    if (dx != 0.0) {
        double u = (x0 - ax) / dx;
        double v = (x1 - ax) / dx;
        t0 = dmax(0.0, dmin(u, v));
        t1 = dmin(1.0, dmax(u, v));
    } else if (ax < x0 || ax > x1) {
        t0 = 1.0, t1 = 0.0;
    }
    if (t0 > t1) {
        *lo = 1, *hi = 0;
        return;
    }
    double ya = ay + t0 * (by - ay);
    double yb = ay + t1 * (by - ay);
    cell_range(dmin(ya, yb) - m, dmax(ya, yb) + m, gy0, cell, ny, lo, hi);
    *lo = imax(*lo, cy0);
    *hi = imin(*hi, cy1);
}

/* A segment whose box spans more than this many cells walks the cells along it (its corridor)
 * rather than every cell of its box: a long diagonal leg meets a few cells per column. */
#define CORRIDOR_MIN_CELLS 16

/* Whether the segment a→b keeps ``margin`` from every piece and stays inside the bounds.
 * ``hint`` (may be NULL): a piece to test first, and where the blocking piece is left when
 * the segment is not free (consecutive queries along a polyline are often blocked by the same
 * piece). Which pieces are tested depends on the segment only: every piece whose cells meet
 * the segment's box grown by the margin, or (a long segment) its corridor, the cells within
 * the margin of it; a piece left out is farther than the margin from the segment in plan
 * view, so the answer is the same either way and does not depend on the hint. */
static int segment_free_h(double ax, double ay, double az, double bx, double by, double bz,
                          const World *w, double margin, int64_t *hint, int probe) {
    if (!(inside_bounds(ax, ay, az, w) && inside_bounds(bx, by, bz, w))) return 0;
    double thr = margin - 1e-9;
    if (thr < 1e-9) thr = 1e-9;
    if (w->f.present && !field_segment_free(&w->f, ax, ay, az, bx, by, bz, thr, probe)) return 0;
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
    int64_t box_cells = nx == 0 ? 0 : (cx1 - cx0 + 1) * (cy1 - cy0 + 1);
    if (box_cells > CORRIDOR_MIN_CELLS) {
        /* a long segment: the cells of its corridor, each piece in the first of them (in
         * column, then row order) that it covers; unless they outnumber the pieces */
        double m = margin + 1e-6;
        int64_t corridor = 0;
        for (int64_t cx = cx0; cx <= cx1 && corridor <= (int64_t)npieces; cx++) {
            int64_t lo, hi;
            corridor_rows(ax, ay, bx, by, m, cx, gx0, gy0, cell, ny, cy0, cy1, &lo, &hi);
            if (lo <= hi) corridor += hi - lo + 1;
        }
        if (corridor <= (int64_t)npieces) {
            for (int64_t cx = cx0; cx <= cx1; cx++) {
                int64_t lo, hi;
                corridor_rows(ax, ay, bx, by, m, cx, gx0, gy0, cell, ny, cy0, cy1, &lo, &hi);
                for (int64_t cy = lo; cy <= hi; cy++) {
                    int64_t c = cx * ny + cy;
                    for (int64_t t = w->cell_start[c]; t < w->cell_start[c + 1]; t++) {
                        int64_t k = w->cell_items[t];
                        const int64_t *pc = w->piece_cells + 4 * k;
                        if (k == first || cy != imax(lo, pc[2])) continue;
                        int earlier = 0; /* the piece met the corridor in an earlier column */
                        for (int64_t e = imax(cx0, pc[0]); e < cx && !earlier; e++) {
                            int64_t l2, h2;
                            corridor_rows(ax, ay, bx, by, m, e, gx0, gy0, cell, ny, cy0, cy1,
                                          &l2, &h2);
                            earlier = l2 <= h2 && l2 <= pc[3] && h2 >= pc[2];
                        }
                        if (earlier) continue;
                        if (seg_piece_dist(ax, ay, az, bx, by, bz, k, w, thr) < thr) {
                            if (hint != NULL) *hint = k;
                            return 0;
                        }
                    }
                }
            }
            return 1;
        }
    }
    /* No grid, or a segment whose box spans more cells than there are pieces (a long leg):
     * walk the pieces in index order instead of the cells, testing the same pieces; "free"
     * does not depend on the order of the tests. */
    if (nx == 0 || box_cells > (int64_t)npieces) {
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

int segment_free(double ax, double ay, double az, double bx, double by, double bz,
                        const World *w, double margin) {
    return segment_free_h(ax, ay, az, bx, by, bz, w, margin, NULL, 0);
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
        if (get_buf(objs[i], &wb->v[i].buf, types[i], ndims[i], 0, names[i]) < 0) {
            world_release(wb);
            return -1;
        }
    }
    World *w = &wb->w;
    w->poly_xy = F64(wb->v[0].buf);
    w->npoly = dim(&wb->v[0].buf, 0);
    w->vmax = dim(&wb->v[0].buf, 1);
    w->poly_n = I64(wb->v[1].buf);
    w->poly_h = F64(wb->v[2].buf);
    w->circ = F64(wb->v[3].buf);
    w->ncirc = dim(&wb->v[3].buf, 0);
    w->npieces = w->npoly + w->ncirc;
    if (need(dim(&wb->v[0].buf, 2) == 2 && dim(&wb->v[1].buf, 0) == w->npoly &&
                 dim(&wb->v[2].buf, 0) == w->npoly &&
                 (w->ncirc == 0 || dim(&wb->v[3].buf, 1) == 4),
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

PyObject *py_point_polygon_dist2d(PyObject *self, PyObject *args) {
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

PyObject *py_point_piece_dist(PyObject *self, PyObject *args) {
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

PyObject *py_seg_piece_dist(PyObject *self, PyObject *args) {
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

PyObject *py_segment_free(PyObject *self, PyObject *args) {
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

/* A batch of segment tests, rows [lo, hi) of p0 → p1 (one thread's share). */
typedef struct {
    const double *p0, *p1;
    unsigned char *out;
    Py_ssize_t lo, hi;
    const World *w;
    double margin;
} SegmentsJob;

static void *segments_run(void *arg) {
    const SegmentsJob *j = (const SegmentsJob *)arg;
    for (Py_ssize_t i = j->lo; i < j->hi; i++)
        j->out[i] = (unsigned char)segment_free(j->p0[3 * i], j->p0[3 * i + 1], j->p0[3 * i + 2],
                                                j->p1[3 * i], j->p1[3 * i + 1], j->p1[3 * i + 2],
                                                j->w, j->margin);
    return NULL;
}

/* A batch shorter than this runs on the caller's thread alone (a thread costs tens of µs). */
#define SEGMENTS_PARALLEL_MIN 256

/* segments_free(p0, p1, W, margin, out[, threads]): out[i] = segment p0[i] → p1[i] is free.
 * With threads > 1 a long batch is shared among that many threads (the caller's and helpers
 * started for it; fewer if the system refuses one): each answer is the same. The GIL is
 * released meanwhile. */
PyObject *py_segments_free(PyObject *self, PyObject *args) {
    PyObject *o0, *o1, *wt, *oo;
    double margin;
    int threads = 1;
    Buf b0 = {0}, b1 = {0}, bo = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOdO|i", &o0, &o1, &wt, &margin, &oo, &threads)) return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(o0, &b0, T_F64, 2, 0, "p0") < 0 || get_buf(o1, &b1, T_F64, 2, 0, "p1") < 0 ||
        get_buf(oo, &bo, T_BOOL, 1, 1, "out") < 0)
        goto done;
    Py_ssize_t n = dim(&b0, 0);
    if (need(dim(&b0, 1) == 3 && dim(&b1, 1) == 3 && dim(&b1, 0) == n && dim(&bo, 0) == n,
             "segments_free: p0, p1 (n, 3), out (n,)") < 0)
        goto done;
    if (threads > STEP_MAX_THREADS) threads = STEP_MAX_THREADS;
    if (threads < 1 || n < SEGMENTS_PARALLEL_MIN || !HAVE_THREADS) threads = 1;
    SegmentsJob jobs[STEP_MAX_THREADS];
    for (int t = 0; t < threads; t++) {
        jobs[t].p0 = F64(b0);
        jobs[t].p1 = F64(b1);
        jobs[t].out = BOOL(bo);
        jobs[t].lo = n * t / threads;
        jobs[t].hi = n * (t + 1) / threads;
        jobs[t].w = &wb.w;
        jobs[t].margin = margin;
    }
    Py_BEGIN_ALLOW_THREADS
#if HAVE_THREADS
    pthread_t helper[STEP_MAX_THREADS];
    int started[STEP_MAX_THREADS] = {0};
    for (int t = 1; t < threads; t++)
        started[t] = pthread_create(&helper[t], NULL, segments_run, &jobs[t]) == 0;
    segments_run(&jobs[0]);
    for (int t = 1; t < threads; t++) {
        if (started[t])
            pthread_join(helper[t], NULL);
        else
            segments_run(&jobs[t]); /* no thread for it: the caller does its share */
    }
#else
    segments_run(&jobs[0]);
#endif
    Py_END_ALLOW_THREADS
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
PyObject *py_farthest_visible(PyObject *self, PyObject *args) {
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
            /* the long chords tried first are mostly blocked: probe them (the same answers) */
            if (segment_free_h(a[0], a[1], a[2], b[0], b[1], b[2], &wb.w, margin, &blocker, 1)) {
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
PyObject *py_largest_free_fraction(PyObject *self, PyObject *args) {
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
PyObject *py_refine_vertices(PyObject *self, PyObject *args) {
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

/* points_clearance(p, W, dist, which): dist pre-filled with inf, which with -1; the
 * terrain's solids are pieces npieces (the ground) and npieces + 1 (the ceiling) */
PyObject *py_points_clearance(PyObject *self, PyObject *args) {
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
        if (w->f.present) { /* the terrain: piece npieces (the ground) or npieces + 1 */
            int kind = -1;
            double d = field_segment_dist(&w->f, q[0], q[1], q[2], q[0], q[1], q[2], dist[i],
                                          &kind, NULL);
            if (kind >= 0 && d < dist[i]) {
                dist[i] = d;
                which[i] = w->npieces + kind;
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

/* A segment whose box spans at most this many grid cells gets a first bound from their pieces */
#define SEED_MAX_CELLS 64

/* An upper bound on the distance from segment a-b to the pieces: the least distance to the
 * pieces in the grid cells its box meets (INFINITY when there is no grid, the box spans more
 * than SEED_MAX_CELLS cells, or they hold none). Started from it, the exact search over every
 * piece skips at once the many whose boxes lie farther. */
static double seed_nearest(const World *w, double ax, double ay, double az, double bx, double by,
                           double bz) {
    double best = INFINITY;
    int64_t nx = (int64_t)w->gmeta[3], ny = (int64_t)w->gmeta[4];
    if (nx == 0) return best;
    double gx0 = w->gmeta[0], gy0 = w->gmeta[1], cell = w->gmeta[2];
    int64_t cx0, cx1, cy0, cy1;
    cell_range(dmin(ax, bx), dmax(ax, bx), gx0, cell, nx, &cx0, &cx1);
    cell_range(dmin(ay, by), dmax(ay, by), gy0, cell, ny, &cy0, &cy1);
    if (cx1 < cx0 || cy1 < cy0 || (cx1 - cx0 + 1) * (cy1 - cy0 + 1) > SEED_MAX_CELLS) return best;
    for (int64_t cx = cx0; cx <= cx1; cx++)
        for (int64_t cy = cy0; cy <= cy1; cy++) {
            int64_t c = cx * ny + cy;
            for (int64_t t = w->cell_start[c]; t < w->cell_start[c + 1]; t++)
                best = dmin(best, seg_piece_dist(ax, ay, az, bx, by, bz, w->cell_items[t], w, -1.0));
        }
    return best;
}

PyObject *py_segments_clearance(PyObject *self, PyObject *args) {
    PyObject *o0, *o1, *wt, *od, *ow;
    Buf b0 = {0}, b1 = {0}, bd = {0}, bw = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOOO", &o0, &o1, &wt, &od, &ow)) return NULL;
    if (world_get(wt, &wb, 11) < 0) return NULL;
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
        /* a little above the nearest piece near it: the search below finds that piece (or a
         * nearer one) again, the first of the least in index order, as it would from dist[i] */
        double seed = seed_nearest(w, ax, ay, az, bx, by, bz);
        if (seed < dist[i]) dist[i] = dmin(dist[i], seed * (1.0 + 1e-12) + 1e-12);
        for (int64_t k = 0; k < w->npieces; k++) {
            if (box_gap(x0, x1, y0, y1, z0, z1, k, w) >= dist[i]) continue;
            double d = seg_piece_dist(ax, ay, az, bx, by, bz, k, w, -1.0);
            if (d < dist[i]) {
                dist[i] = d;
                which[i] = k;
            }
        }
        if (w->f.present) { /* the terrain: piece npieces (the ground) or npieces + 1 */
            int kind = -1;
            double d = field_segment_dist(&w->f, ax, ay, az, bx, by, bz, dist[i], &kind, NULL);
            if (kind >= 0 && d < dist[i]) {
                dist[i] = d;
                which[i] = w->npieces + kind;
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
PyObject *py_cells_count(PyObject *self, PyObject *args) {
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
PyObject *py_cells_fill(PyObject *self, PyObject *args) {
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

