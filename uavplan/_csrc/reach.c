/* uavplan._ckernels: the reachability rule of the swarm planners (a node is reachable when
 * the segment from the previous node keeps the margin) with its memo and the clearance
 * table behind its cheap answers (uavplan/planners/_kernels.py). */
#include "kernels.h"

/* round_grid(values, out): round_grid of every value (the tests hold it to _kernels._round) */
PyObject *py_round_grid(PyObject *self, PyObject *args) {
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

int node_resolve(int64_t j, double y0, double z0, double y1, double z1, const Reach *r) {
    int free_ = segment_to_node_free(j, y0, z0, y1, z1, r);
    int64_t key = memo_key(j, y0, z0, y1, z1);
    if (key >= 0) {
        int64_t slot = memo_slot(r->keys, r->nkeys, key);
        if (slot >= 0) STORE_RELAXED(&r->keys[slot], 2 * key + (free_ ? 1 : 0));
    }
    return free_ ? 1 : 0;
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
PyObject *py_node_status(PyObject *self, PyObject *args) {
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
PyObject *py_node_resolve(PyObject *self, PyObject *args) {
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
PyObject *py_reachable(PyObject *self, PyObject *args) {
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

/* clearance_table(cols, ylim, iy_lo, iy_hi, iz_lo, iz_hi, dy, dz, world, cap, tab, exact)
 * with tab pre-filled with cap; cap = tab's fill value is passed too. Distances below
 * ``exact`` are exact; above it the terrain's may be lower bounds (never above the distance;
 * the reachability rule's cheap answers stay right: a node is refused exactly when its
 * distance is below a margin under ``exact``, and d0 + d1 - length bounds a segment). */
PyObject *py_clearance_table(PyObject *self, PyObject *args) {
    PyObject *oc, *ol, *wt, *ot;
    long long iy_lo, iy_hi, iz_lo, iz_hi;
    double dy, dz, cap, exact = INFINITY;
    Buf bc = {0}, bl = {0}, bt = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOLLLLddOdO|d", &oc, &ol, &iy_lo, &iy_hi, &iz_lo, &iz_hi, &dy,
                          &dz, &wt, &cap, &ot, &exact))
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
    if (w->f.present) { /* the terrain's solids, one column of nodes at a time */
        FieldBlocks fb;
        if (field_blocks_init(&w->f, &fb) < 0) goto done;
        for (int64_t j = 0; j < n_cols + 1; j++) {
            for (int64_t a = 0; a < ny; a++) {
                double yu = (double)(a + iy_lo);
                double px = cols[4 * j + 0] + yu * dy * cols[4 * j + 2];
                double py = cols[4 * j + 1] + yu * dy * cols[4 * j + 3];
                field_column(&w->f, &fb, px, py, (double)iz_lo * dz, dz, nz,
                             tab + (j * ny + a) * nz, exact);
            }
        }
        field_blocks_free(&fb);
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
