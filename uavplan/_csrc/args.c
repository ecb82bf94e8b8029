/* uavplan._ckernels: the buffer protocol, and the named structures the Python side passes
 * (the world, the reachability rule's inputs, the energy's inputs, the fitness cache, the
 * SPSA step's setup and draws). A structure is any object with the fields of its table below,
 * read by attribute name into a C struct once per call: the tables here are the only place
 * that knows its fields, and the module exports them (FIELDS) for the Python side to check
 * its classes against. */
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
 * Named structures
 */

/* A structure's fields: read by name; ``names`` are their interned attribute names (made by
 * args_init). */
typedef struct {
    const char *what;   /* in messages */
    const char *python; /* the Python class uavplan builds it as */
    int n;
    const Field *fields;
    PyObject **names;
} Structure;

/* A field of structure ``s``: its attribute ``n`` (and "s.n" for messages) */
#define F(s, n, kind, ndim, writable) {#n, #s "." #n, kind, ndim, writable}

/* uavplan._geom.KernelWorld. A kernel reads the first 5 (pieces), 7 (and the bounds) or 11
 * (and the cell grid), and always the last 5 (the height field). */
static const Field WORLD_FIELDS[WORLD_BUFS] = {
    F(world, poly_xy, T_F64, 3, 0),
    F(world, poly_n, T_I64, 1, 0),
    F(world, poly_h, T_F64, 1, 0),
    F(world, circ, T_F64, 2, 0),
    F(world, box, T_F64, 2, 0),
    F(world, hp, T_F64, 2, 0),
    F(world, zlim, T_F64, 1, 0),
    F(world, gmeta, T_F64, 1, 0),
    F(world, cell_start, T_I64, 1, 0),
    F(world, cell_items, T_I64, 1, 0),
    F(world, piece_cells, T_I64, 2, 0),
    F(world, hf_xy, T_F64, 3, 0),
    F(world, hf_z, T_F64, 2, 0),
    F(world, hf_slope, T_F64, 2, 0),
    F(world, hf_meta, T_F64, 1, 0),
    F(world, hf_blocks, T_F64, 3, 0),
};
#define WORLD_FIELD0 11 /* the height field's first field */

/* uavplan.planners._kernels.Reach */
enum { R_WORLD, R_COLS, R_MEMO, R_TABLE, R_TABLE_OFF, R_STEPS, R_START, R_GOAL, R_MARGIN,
       R_COUNTS, R_N };
typedef char reach_fields_check[R_N == REACH_NFIELDS ? 1 : -1];
static const Field REACH_FIELDS[R_N] = {
    [R_WORLD] = F(reach, world, K_OBJECT, 0, 0),
    [R_COLS] = F(reach, cols, T_F64, 2, 0),
    [R_MEMO] = F(reach, memo, T_I64, 1, 1),
    [R_TABLE] = F(reach, table, T_F64, 3, 0),
    [R_TABLE_OFF] = F(reach, table_off, T_I64, 1, 0),
    [R_STEPS] = F(reach, steps, T_F64, 1, 0),
    [R_START] = F(reach, start_m, T_F64, 1, 0),
    [R_GOAL] = F(reach, goal_m, T_F64, 1, 0),
    [R_MARGIN] = F(reach, margin, K_REAL, 0, 0),
    [R_COUNTS] = F(reach, counts, T_I64, 1, 1),
};

/* uavplan.path.energy.EnergyArgs */
enum { E_START, E_GOAL, E_COLS, E_DX, E_DY, E_DZ, E_N_SUB, E_K0, E_K1, E_MU0, E_K2, E_SMOOTH,
       E_STRAIGHT, E_PHYS, E_N };
typedef char energy_fields_check[E_N == ENERGY_NFIELDS ? 1 : -1];
static const Field ENERGY_FIELDS[E_N] = {
    [E_START] = F(energy, start_yz, T_F64, 1, 0),
    [E_GOAL] = F(energy, goal_yz, T_F64, 1, 0),
    [E_COLS] = F(energy, cols, T_F64, 2, 0),
    [E_DX] = F(energy, dx, K_REAL, 0, 0),
    [E_DY] = F(energy, dy, K_REAL, 0, 0),
    [E_DZ] = F(energy, dz, K_REAL, 0, 0),
    [E_N_SUB] = F(energy, n_sub, K_INT, 0, 0),
    [E_K0] = F(energy, k0, K_REAL, 0, 0),
    [E_K1] = F(energy, k1, K_REAL, 0, 0),
    [E_MU0] = F(energy, mu0, K_REAL, 0, 0),
    [E_K2] = F(energy, k2, K_REAL, 0, 0),
    [E_SMOOTH] = F(energy, smooth, K_INT, 0, 0),
    [E_STRAIGHT] = F(energy, straight, K_FLAG, 0, 0),
    [E_PHYS] = F(energy, phys, T_F64, 1, 0),
};

/* uavplan.planners._kernels.EnergyCache */
enum { C_FILLED, C_VALUES, C_PATHS, C_N };
typedef char cache_fields_check[C_N == CACHE_NFIELDS ? 1 : -1];
static const Field CACHE_FIELDS[C_N] = {
    [C_FILLED] = F(cache, filled, T_BOOL, 1, 1),
    [C_VALUES] = F(cache, values, T_F64, 1, 1),
    [C_PATHS] = F(cache, paths, T_I32, 2, 1),
};

/* uavplan.planners._kernels.StepSetup: what every step of one search shares */
enum { S_REACH, S_ENERGY, S_LINE, S_GOAL_U, S_N_PROD, S_ITERATIONS, S_T_MAX, S_V_MIN, S_V_MAX,
       S_WINDOW, S_FLAGS, S_WARNING_VALUE, S_CACHE, S_THREADS, S_N };
typedef char setup_fields_check[S_N == SETUP_NFIELDS ? 1 : -1];
static const Field SETUP_FIELDS[S_N] = {
    [S_REACH] = F(setup, reach, K_OBJECT, 0, 0),
    [S_ENERGY] = F(setup, energy, K_OBJECT, 0, 0),
    [S_LINE] = F(setup, line, T_F64, 2, 0),
    [S_GOAL_U] = F(setup, goal_u, T_F64, 1, 0),
    [S_N_PROD] = F(setup, n_prod, K_INT, 0, 0),
    [S_ITERATIONS] = F(setup, iterations, K_INT, 0, 0),
    [S_T_MAX] = F(setup, t_max, K_INT, 0, 0),
    [S_V_MIN] = F(setup, v_min, K_INT, 0, 0),
    [S_V_MAX] = F(setup, v_max, K_INT, 0, 0),
    [S_WINDOW] = F(setup, window, K_INT, 0, 0),
    [S_FLAGS] = F(setup, flags, K_INT, 0, 0),
    [S_WARNING_VALUE] = F(setup, warning_value, K_REAL, 0, 0),
    [S_CACHE] = F(setup, cache, K_OBJECT, 0, 0),
    [S_THREADS] = F(setup, threads, K_INT, 0, 0),
};

/* uavplan.planners._kernels.StepDraws: the random numbers of one step */
enum { D_WARN, D_PDRAW, D_SIGNS, D_AWARE, D_SEEDS1, D_SEEDS2, D_N };
typedef char draws_fields_check[D_N == DRAWS_NFIELDS ? 1 : -1];
static const Field DRAWS_FIELDS[D_N] = {
    [D_WARN] = F(draws, warn, K_REAL, 0, 0),
    [D_PDRAW] = F(draws, pdraw, T_F64, 1, 0),
    [D_SIGNS] = F(draws, signs, T_F64, 3, 0),
    [D_AWARE] = F(draws, aware, T_I64, 1, 0),
    [D_SEEDS1] = F(draws, seeds1, T_U64, 1, 0),
    [D_SEEDS2] = F(draws, seeds2, T_U64, 1, 0),
};

static PyObject *world_names[WORLD_BUFS], *reach_names[R_N], *energy_names[E_N],
    *cache_names[C_N], *setup_names[S_N], *draws_names[D_N];

static Structure WORLD = {"world", "uavplan._geom.KernelWorld", WORLD_BUFS, WORLD_FIELDS,
                          world_names};
static Structure REACH = {"reach", "uavplan.planners._kernels.Reach", R_N, REACH_FIELDS,
                          reach_names};
static Structure ENERGY = {"energy", "uavplan.path.energy.EnergyArgs", E_N, ENERGY_FIELDS,
                           energy_names};
static Structure CACHE = {"cache", "uavplan.planners._kernels.EnergyCache", C_N, CACHE_FIELDS,
                          cache_names};
static Structure SETUP = {"setup", "uavplan.planners._kernels.StepSetup", S_N, SETUP_FIELDS,
                          setup_names};
static Structure DRAWS = {"draws", "uavplan.planners._kernels.StepDraws", D_N, DRAWS_FIELDS,
                          draws_names};
static Structure *const STRUCTURES[] = {&WORLD, &REACH, &ENERGY, &CACHE, &SETUP, &DRAWS};
#define N_STRUCTURES ((int)(sizeof(STRUCTURES) / sizeof(STRUCTURES[0])))

void values_release(Value *v, int n) {
    for (int i = 0; i < n; i++) {
        rel(&v[i].buf);
        Py_CLEAR(v[i].obj);
    }
}

/* Reads fields ``lo`` .. ``n`` - 1 of structure ``s`` from ``o`` into ``v`` (zeroed first):
 * arrays acquired, numbers converted, objects as new references. On an error nothing of
 * them is held. */
static int values_range(PyObject *o, const Structure *s, int lo, int n, Value *v) {
    memset(v + lo, 0, sizeof(Value) * (size_t)(n - lo));
    for (int i = lo; i < n; i++) {
        const Field *f = &s->fields[i];
        PyObject *a = PyObject_GetAttr(o, s->names[i]);
        if (a == NULL) {
            if (PyErr_ExceptionMatches(PyExc_AttributeError)) {
                PyErr_Format(PyExc_TypeError, "%s: expected a %s (no field '%s' in a %.80s)",
                             s->what, s->python, f->name, Py_TYPE(o)->tp_name);
            }
            values_release(v + lo, i - lo);
            return -1;
        }
        int bad = 0;
        switch (f->kind) {
        case K_OBJECT: v[i].obj = a; a = NULL; break;
        case K_REAL:
            v[i].real = PyFloat_AsDouble(a);
            bad = v[i].real == -1.0 && PyErr_Occurred();
            break;
        case K_INT:
            v[i].integer = PyLong_AsLongLong(a);
            bad = v[i].integer == -1 && PyErr_Occurred();
            break;
        case K_FLAG:
            v[i].integer = PyObject_IsTrue(a);
            bad = v[i].integer < 0;
            break;
        default: bad = get_buf(a, &v[i].buf, f->kind, f->ndim, f->writable, f->qual) < 0;
        }
        Py_XDECREF(a);
        if (bad) {
            values_release(v + lo, i + 1 - lo);
            return -1;
        }
    }
    return 0;
}

/* The first ``n`` fields (see values_range). */
static int values_get(PyObject *o, const Structure *s, int n, Value *v) {
    return values_range(o, s, 0, n, v);
}

/* ------------------------------------------------------------------------------------------
 * The world, the reachability rule, the energy, the fitness cache, the SPSA step
 */

void world_release(WorldBufs *wb) { values_release(wb->v, WORLD_BUFS); }

/* The height field of a world whose field arrays are held (an empty field: none). */
static int field_get(WorldBufs *wb) {
    const Buf *bxy = &wb->v[WORLD_FIELD0].buf, *bz = &wb->v[WORLD_FIELD0 + 1].buf,
              *bs = &wb->v[WORLD_FIELD0 + 2].buf, *bm = &wb->v[WORLD_FIELD0 + 3].buf,
              *bb = &wb->v[WORLD_FIELD0 + 4].buf;
    HField *f = &wb->w.f;
    memset(f, 0, sizeof(*f));
    Py_ssize_t nr = dim(bz, 0), nc = dim(bz, 1);
    if (need(dim(bxy, 0) == nr && dim(bxy, 1) == nc && dim(bxy, 2) == 2 &&
                 dim(bm, 0) == FIELD_META && dim(bb, 2) == 2 &&
                 (nr < 2 || nc < 2 ||
                  (dim(bs, 0) == nr - 1 && dim(bs, 1) == nc - 1 &&
                   dim(bb, 0) == (nr - 2) / FIELD_BLOCK + 1 &&
                   dim(bb, 1) == (nc - 2) / FIELD_BLOCK + 1)),
             "world: inconsistent height field arrays") < 0) {
        world_release(wb);
        return -1;
    }
    if (nr < 2 || nc < 2) return 0;
    const double *m = F64(*bm);
    f->xy = F64(*bxy);
    f->z = F64(*bz);
    f->slope = F64(*bs);
    f->blk = F64(*bb);
    f->nr = nr;
    f->nc = nc;
    f->nbr = dim(bb, 0);
    f->nbc = dim(bb, 1);
    f->ox = m[0];
    f->oy = m[1];
    f->c = m[2];
    f->s = m[3];
    memcpy(f->aff, m + 4, sizeof(f->aff));
    f->slack = m[10];
    f->per_m = m[11];
    f->lift = m[12];
    f->roof = m[13];
    f->zmax = m[14];
    f->zmin = m[15];
    f->present = 1;
    return 0;
}

/* Reads a world: ``n_min`` = 5 (pieces only), 7 (and bounds) or 11 (and the grid) of its
 * fields, and its height field. */
int world_get(PyObject *o, WorldBufs *wb, int n_min) {
    memset(wb, 0, sizeof(*wb));
    int n = n_min;
    if (values_get(o, &WORLD, n, wb->v) < 0) return -1;
    if (values_range(o, &WORLD, WORLD_FIELD0, WORLD_BUFS, wb->v) < 0) {
        world_release(wb);
        return -1;
    }
    if (field_get(wb) < 0) return -1;
    Value *v = wb->v;
#define B(i) (&v[i].buf)
    World *w = &wb->w;
    w->poly_xy = F64(*B(0));
    w->npoly = dim(B(0), 0);
    w->vmax = dim(B(0), 1);
    w->poly_n = I64(*B(1));
    w->poly_h = F64(*B(2));
    w->circ = F64(*B(3));
    w->ncirc = dim(B(3), 0);
    w->box = F64(*B(4));
    w->npieces = dim(B(4), 0);
    if (need(dim(B(0), 2) == 2 && dim(B(1), 0) == w->npoly && dim(B(2), 0) == w->npoly &&
                 (w->ncirc == 0 || dim(B(3), 1) == 4) && w->npieces == w->npoly + w->ncirc &&
                 dim(B(4), 1) == 5,
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
        w->hp = F64(*B(5));
        w->nhp = dim(B(5), 0);
        w->zlim = F64(*B(6));
        if (need((w->nhp == 0 || dim(B(5), 1) == 3) && dim(B(6), 0) == 2,
                 "world: inconsistent bounds arrays") < 0) {
            world_release(wb);
            return -1;
        }
    }
    if (n >= 11) {
        w->gmeta = F64(*B(7));
        w->cell_start = I64(*B(8));
        w->cell_items = I64(*B(9));
        w->piece_cells = I64(*B(10));
        Py_ssize_t nx = dim(B(7), 0) >= 5 ? (Py_ssize_t)w->gmeta[3] : -1;
        Py_ssize_t ny = dim(B(7), 0) >= 5 ? (Py_ssize_t)w->gmeta[4] : -1;
        if (need(nx >= 0 && ny >= 0 &&
                     (w->npieces == 0 || nx == 0 ||
                      (dim(B(8), 0) == nx * ny + 1 && dim(B(10), 0) == w->npieces &&
                       dim(B(10), 1) == 4)),
                 "world: inconsistent cell grid") < 0) {
            world_release(wb);
            return -1;
        }
        w->grid = 1;
    }
#undef B
    return 0;
}

void reach_release(ReachBufs *rb) {
    world_release(&rb->wb);
    values_release(rb->v, R_N);
}

int reach_get(PyObject *o, Reach *r, ReachBufs *rb) {
    memset(rb, 0, sizeof(*rb));
    memset(r, 0, sizeof(*r));
    Value *v = rb->v;
    if (values_get(o, &REACH, R_N, v) < 0) return -1;
    if (world_get(v[R_WORLD].obj, &rb->wb, 11) < 0) {
        values_release(v, R_N);
        return -1;
    }
    const Buf *cols = &v[R_COLS].buf, *memo = &v[R_MEMO].buf, *table = &v[R_TABLE].buf;
    int64_t nkeys = dim(memo, 0);
    if (need(dim(cols, 1) == 4 && dim(cols, 0) >= 2 && dim(table, 0) == dim(cols, 0) &&
                 dim(&v[R_TABLE_OFF].buf, 0) == 2 && dim(&v[R_STEPS].buf, 0) == 3 &&
                 dim(&v[R_START].buf, 0) == 3 && dim(&v[R_GOAL].buf, 0) == 3 &&
                 dim(&v[R_COUNTS].buf, 0) >= 2 && nkeys > 0 && (nkeys & (nkeys - 1)) == 0,
             "reach: inconsistent arrays") < 0) {
        reach_release(rb);
        return -1;
    }
    double margin = v[R_MARGIN].real;
    r->w = rb->wb.w;
    r->cols = F64(*cols);
    r->ncols = dim(cols, 0);
    r->dy = F64(v[R_STEPS].buf)[1];
    r->dz = F64(v[R_STEPS].buf)[2];
    r->margin = margin;
    r->lim = margin_limit(margin);
    r->tab = F64(*table);
    r->tn0 = dim(table, 0);
    r->tny = dim(table, 1);
    r->tnz = dim(table, 2);
    r->off = I64(v[R_TABLE_OFF].buf);
    r->keys = I64(*memo);
    r->nkeys = nkeys;
    r->start_m = F64(v[R_START].buf);
    r->goal_m = F64(v[R_GOAL].buf);
    r->counts = I64(v[R_COUNTS].buf);
    return 0;
}

void energy_release(Energy *e, EnergyBufs *eb) {
    free(e->work);
    e->work = NULL;
    values_release(eb->v, E_N);
}

/* Reads an energy for paths of ``inner`` nodes; its work buffers allocated by energy_init. */
int energy_get(PyObject *o, Energy *e, EnergyBufs *eb, int64_t inner) {
    memset(e, 0, sizeof(*e));
    Value *v = eb->v;
    if (values_get(o, &ENERGY, E_N, v) < 0) return -1;
    long long n_sub = v[E_N_SUB].integer;
    int straight = (int)v[E_STRAIGHT].integer;
    const Buf *cols = &v[E_COLS].buf;
    if (need(dim(&v[E_START].buf, 0) >= 2 && dim(&v[E_GOAL].buf, 0) >= 2 && n_sub >= 1 &&
                 (straight || (dim(cols, 0) >= inner + 2 && dim(cols, 1) == 4)),
             "energy: inconsistent arrays") < 0) {
        values_release(v, E_N);
        return -1;
    }
    e->start_yz = F64(v[E_START].buf);
    e->goal_yz = F64(v[E_GOAL].buf);
    e->cols = F64(*cols);
    e->dx = v[E_DX].real;
    e->dy = v[E_DY].real;
    e->dz = v[E_DZ].real;
    e->k0 = v[E_K0].real;
    e->k1 = v[E_K1].real;
    e->mu0 = v[E_MU0].real;
    e->k2 = v[E_K2].real;
    e->n_sub = n_sub;
    e->smooth = v[E_SMOOTH].integer;
    e->inner = inner;
    e->straight = straight;
    e->n_phys = dim(&v[E_PHYS].buf, 0);
    e->phys = e->n_phys > 0 ? F64(v[E_PHYS].buf) : NULL;
    if (e->phys != NULL && phys_check(e->phys, e->n_phys) < 0) {
        values_release(v, E_N);
        return -1;
    }
    if (energy_init(e) < 0) {
        values_release(v, E_N);
        return -1;
    }
    return 0;
}

void step_args_release(StepArgs *a) {
    energy_release(&a->e, &a->eb);
    reach_release(&a->rb);
    values_release(a->cache, C_N);
    values_release(a->setup, S_N);
    values_release(a->draws, D_N);
}

/* Reads a step's setup and draws for paths of ``inner`` nodes, with the reachability rule,
 * the energy and the fitness cache (if any) they hold. */
int step_args_get(PyObject *setup, PyObject *draws, int64_t inner, StepArgs *a) {
    memset(a, 0, sizeof(*a));
    Value *s = a->setup, *d = a->draws, *c = a->cache;
    if (values_get(setup, &SETUP, S_N, s) < 0) return -1;
    if (values_get(draws, &DRAWS, D_N, d) < 0) {
        values_release(s, S_N);
        return -1;
    }
    if (reach_get(s[S_REACH].obj, &a->r, &a->rb) < 0) goto fail;
    if (energy_get(s[S_ENERGY].obj, &a->e, &a->eb, inner) < 0) goto fail;
    if (s[S_CACHE].obj != Py_None) {
        if (values_get(s[S_CACHE].obj, &CACHE, C_N, c) < 0) goto fail;
        a->has_cache = 1;
        a->filled = &c[C_FILLED].buf;
        a->values = &c[C_VALUES].buf;
        a->paths = &c[C_PATHS].buf;
    }
    a->line = &s[S_LINE].buf;
    a->goal_u = &s[S_GOAL_U].buf;
    a->n_prod = s[S_N_PROD].integer;
    a->iterations = s[S_ITERATIONS].integer;
    a->t_max = s[S_T_MAX].integer;
    a->v_min = s[S_V_MIN].integer;
    a->v_max = s[S_V_MAX].integer;
    a->window = s[S_WINDOW].integer;
    a->flags = s[S_FLAGS].integer;
    a->warning_value = s[S_WARNING_VALUE].real;
    a->threads = s[S_THREADS].integer;
    a->warn = d[D_WARN].real;
    a->pdraw = &d[D_PDRAW].buf;
    a->signs = &d[D_SIGNS].buf;
    a->aware = &d[D_AWARE].buf;
    a->seeds1 = &d[D_SEEDS1].buf;
    a->seeds2 = &d[D_SEEDS2].buf;
    return 0;
fail:
    step_args_release(a);
    return -1;
}

/* ------------------------------------------------------------------------------------------
 * Set-up
 */

int args_init(void) {
    for (int k = 0; k < N_STRUCTURES; k++) {
        Structure *s = STRUCTURES[k];
        for (int i = 0; i < s->n; i++) {
            if (s->names[i] == NULL) s->names[i] = PyUnicode_InternFromString(s->fields[i].name);
            if (s->names[i] == NULL) return -1;
        }
    }
    return 0;
}

static const char *kind_name(int kind) {
    switch (kind) {
    case K_REAL: return "float";
    case K_INT: return "int";
    case K_FLAG: return "bool";
    case K_OBJECT: return "object";
    case T_F64: return "float64";
    case T_I64: return "int64";
    case T_BOOL: return "bool";
    case T_I32: return "int32";
    default: return "uint64";
    }
}

/* {structure: ((field, kind, ndim, writable), ...)}: kind a numpy dtype name for an array
 * (ndim >= 1; writable: the kernels write it), else "float", "int", "bool" or "object"
 * (ndim 0) */
PyObject *args_fields(void) {
    PyObject *out = PyDict_New();
    if (out == NULL) return NULL;
    for (int k = 0; k < N_STRUCTURES; k++) {
        const Structure *s = STRUCTURES[k];
        PyObject *t = PyTuple_New(s->n);
        if (t == NULL) goto fail;
        for (int i = 0; i < s->n; i++) {
            const Field *f = &s->fields[i];
            int array = f->kind < K_REAL;
            PyObject *item = Py_BuildValue("(ssiO)", f->name, kind_name(f->kind),
                                           array ? f->ndim : 0,
                                           f->writable ? Py_True : Py_False);
            if (item == NULL) {
                Py_DECREF(t);
                goto fail;
            }
            PyTuple_SET_ITEM(t, i, item);
        }
        int rc = PyDict_SetItemString(out, s->what, t);
        Py_DECREF(t);
        if (rc < 0) goto fail;
    }
    return out;
fail:
    Py_DECREF(out);
    return NULL;
}
