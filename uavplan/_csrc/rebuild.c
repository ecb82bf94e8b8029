/* uavplan._ckernels: what every swarm planner's population goes through under the
 * reachability rule (uavplan/planners/_kernels.py): the initialisation toward the target
 * (eq. 8-10), the generic proposal-and-repair step with eq. 12's escape, the moving-average
 * repair (eq. 13), feasibility. */
#include "kernels.h"

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

/* init_population(n_pop, n_inner, start_u, goal_u, half_window, t_max, max_attempts, window,
 * reach, capsule, nodes, ok) -> deadlocks */
PyObject *py_init_population(PyObject *self, PyObject *args) {
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
int64_t rebuild_core(const double *base, int64_t n_pop, int64_t n_inner,
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

PyObject *py_rebuild(PyObject *self, PyObject *args) {
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
void mar_core(double *nodes, int64_t n_pop, int64_t n_inner, const double *goal_u,
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

PyObject *py_moving_average_repair(PyObject *self, PyObject *args) {
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
PyObject *py_paths_feasible(PyObject *self, PyObject *args) {
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
