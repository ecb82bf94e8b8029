/* uavplan._ckernels: the buffer protocol, and the named structures the Python side passes
 * (the world, the reachability rule's inputs, the energy's inputs), read into C structs. */
#include "kernels.h"

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
int get_buf(PyObject *obj, Buf *b, int t, int ndim, int writable, const char *what) {
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

void rel(Buf *b) {
    if (b->held) {
        PyBuffer_Release(&b->view);
        b->held = 0;
    }
}

int need(int cond, const char *msg) {
    if (!cond) {
        PyErr_SetString(PyExc_ValueError, msg);
        return -1;
    }
    return 0;
}

/* ------------------------------------------------------------------------------------------
 * The world tuple (see uavplan.world.World.kernel_args)
 */

void world_release(WorldBufs *wb) {
    for (int i = 0; i < WORLD_BUFS; i++) rel(&wb->b[i]);
}

/* Parse a world tuple; ``n_min`` = 5 (pieces only), 7 (and bounds) or 11 (and the grid). */
int world_get(PyObject *tup, WorldBufs *wb, int n_min) {
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

void reach_release(ReachBufs *rb) {
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
int reach_get(PyObject *o, Reach *r, ReachBufs *rb) {
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

/* An energy tuple (start_yz, goal_yz, cols, dx, dy, dz, n_sub, k0, k1, mu0, k2, smooth,
 * straight) as PathProblem.energy_args builds it; work buffers allocated by energy_init. */
int energy_get(PyObject *o, Energy *e, Buf *bufs, int64_t inner) {
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

