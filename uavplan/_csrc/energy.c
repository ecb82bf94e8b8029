/* uavplan._ckernels: the energy fitness of the paper (eq. 1-2) on the cubic spline through a
 * path's nodes (uavplan/path/energy.py), the polyline energy, and the physical fitness (the
 * power model's watt-hours on the same spline). */
#include "kernels.h"

PyObject *py_polyline_energy(PyObject *self, PyObject *args) {
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
PyObject *py_spline_points(PyObject *self, PyObject *args) {
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

int energy_init(Energy *e) {
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
void energy_knots(const double *nodes, const Energy *e) {
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

/* ------------------------------------------------------------------------------------------
 * The physical fitness (planner.energy: physical): the watt-hours of the power model
 * (uavplan/airframe/power.py, legs.py) along the spline's samples, each step a leg flown at
 * the commanded ground speed, its climb no faster than the climb or descent rate, through a
 * wind tabulated by height. The same expressions as the Python model; tests hold the two to
 * each other (tests/test_physical_fitness.py). ``phys`` (PhysicalFitness.table in
 * uavplan/path/energy.py): the scalars below, then PHYS_NZ rows of (wind x, wind y in the path
 * frame, air density) at heights PHYS_Z0 + i·PHYS_DZ, linear in between, clamped at the ends.
 */
enum { PHYS_WEIGHT, PHYS_AREA, PHYS_FM, PHYS_KAPPA, PHYS_ETA, PHYS_CT, PHYS_DRAG, PHYS_AVIONICS,
       PHYS_SCALE, PHYS_VMAX, PHYS_SPEED, PHYS_CLIMB, PHYS_DESCENT, PHYS_K1, PHYS_K2, PHYS_K3,
       PHYS_K4, PHYS_Z0, PHYS_DZ, PHYS_NZ, PHYS_HEAD };

int phys_check(const double *ph, int64_t n) {
    if (n < PHYS_HEAD) return need(0, "energy.phys: too short");
    double nz = ph[PHYS_NZ];
    if (!(nz >= 1.0 && nz == floor(nz) && n == PHYS_HEAD + 3 * (int64_t)nz))
        return need(0, "energy.phys: its table does not match its length");
    for (int i = 0; i < PHYS_K1; i++)
        if (!(ph[i] > 0.0) && i != PHYS_AVIONICS && i != PHYS_DRAG)
            return need(0, "energy.phys: a vehicle figure is not positive");
    if (!(ph[PHYS_DZ] > 0.0)) return need(0, "energy.phys: the table step is not positive");
    return 0;
}

/* Leishman's g(x): induced velocity over v_f in axial flight (power.py _vertical_factor) */
static double phys_vertical(double x, const double *ph) {
    double kappa = ph[PHYS_KAPPA], half = x / 2.0;
    if (x >= 0.0) return kappa / (half + sqrt(half * half + 1.0));
    if (x >= -2.0)
        return kappa +
               x * (ph[PHYS_K1] + x * (ph[PHYS_K2] + x * (ph[PHYS_K3] + x * ph[PHYS_K4])));
    double d = half * half - 1.0;
    return kappa / (-half + sqrt(d > 0.0 ? d : 0.0));
}

/* Electrical power (W) at airspeed v, vertical speed vz, air density rho (power.py
 * _shaft_terms and power_terms) */
static double phys_power(const double *ph, double v, double vz, double rho) {
    double w = ph[PHYS_WEIGHT], area = ph[PHYS_AREA], kappa = ph[PHYS_KAPPA];
    double drag = 0.5 * rho * ph[PHYS_DRAG] * v * v;
    double thrust = sqrt(w * w + drag * drag);
    double v_h = sqrt(thrust / (2.0 * rho * area));
    double p0 = thrust * v_h * (1.0 / ph[PHYS_FM] - kappa);
    double tip_sq = thrust / (rho * area * ph[PHYS_CT]);
    double blade = p0 * (1.0 + 3.0 * v * v / tip_sq);
    double a = v * v / (2.0 * v_h * v_h);
    double v_f = v_h * sqrt(1.0 / (sqrt(1.0 + a * a) + a));
    double induced = w * vz + thrust * v_f * phys_vertical(vz / v_f, ph);
    if (induced < 0.0) induced = 0.0;
    double scale = ph[PHYS_SCALE];
    return ph[PHYS_AVIONICS] + (scale * blade + scale * induced + scale * (drag * v)) / ph[PHYS_ETA];
}

/* Watt-hours of the steps (ex, ey, ez, length) ending at samples 1..ns-1 of heights qz */
static double phys_energy(const Energy *e, const double *qz, const double *vx, const double *vy,
                          const double *vz, const double *vl, int64_t ns) {
    const double *ph = e->phys, *table = ph + PHYS_HEAD;
    int64_t nz = (int64_t)ph[PHYS_NZ];
    double z0 = ph[PHYS_Z0], dz = ph[PHYS_DZ], vmax = ph[PHYS_VMAX], speed = ph[PHYS_SPEED];
    double joules = 0.0;
    for (int64_t t = 1; t < ns; t++) {
        if (!(vl[t] > 1e-12)) continue;
        double ex = vx[t], ey = vy[t], ez = vz[t];
        /* the wind and the density at the step's mean height */
        double f = ((qz[t - 1] + qz[t]) / 2.0 - z0) / dz;
        if (f < 0.0) f = 0.0;
        if (f > (double)(nz - 1)) f = (double)(nz - 1);
        int64_t i = (int64_t)f;
        if (i > nz - 2) i = nz > 1 ? nz - 2 : 0;
        double u = nz > 1 ? f - (double)i : 0.0;
        const double *r0 = table + 3 * i, *r1 = nz > 1 ? r0 + 3 : r0;
        double wx = r0[0] + u * (r1[0] - r0[0]), wy = r0[1] + u * (r1[1] - r0[1]);
        double rho = r0[2] + u * (r1[2] - r0[2]);
        double h = sqrt(ex * ex + ey * ey);
        double ux = 0.0, uy = 0.0, t_h = 0.0;
        if (h > 0.0) {
            ux = ex / h;
            uy = ey / h;
            double g = speed, ax = speed * ux - wx, ay = speed * uy - wy;
            if (ax * ax + ay * ay > vmax * vmax) { /* the headwind caps the ground speed */
                double along = ux * wx + uy * wy;
                double disc = vmax * vmax - (wx * wx + wy * wy - along * along);
                double root = along + sqrt(disc > 0.0 ? disc : 0.0);
                if (root < g) g = root;
            }
            t_h = h / g;
        }
        double t_v = fabs(ez) / (ez > 0.0 ? ph[PHYS_CLIMB] : ph[PHYS_DESCENT]);
        double travel = t_h > t_v ? t_h : t_v;
        if (!(travel > 0.0)) continue;
        double gs = h / travel;
        double ax = gs * ux - wx, ay = gs * uy - wy;
        joules += phys_power(ph, sqrt(ax * ax + ay * ay), ez / travel, rho) * travel;
    }
    return joules / 3600.0;
}

/* Whether energy_bound is a lower bound for these weights: k0, k2, k1·μ0 >= 0 (the
 * configuration's bounds), and the paper's fitness (the physical one has none). */
int bound_valid(const Energy *e) {
    return e->phys == NULL && e->k0 >= 0.0 && e->k2 >= 0.0 && e->k1 * e->mu0 >= 0.0;
}

/* energy_bound of the knots energy_knots left in e->work. */
double bound_from_knots(const Energy *e) {
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
double energy_bound(const double *nodes, const Energy *e) {
    if (!bound_valid(e)) return -1.0;
    energy_knots(nodes, e);
    return bound_from_knots(e);
}

/* energy_one of the knots energy_knots left in e->work. */
double energy_from_knots(const Energy *e) {
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
    if (e->phys != NULL) return phys_energy(e, qz, vx, vy, vz, vl, ns);
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
double energy_one(const double *nodes, const Energy *e) {
    energy_knots(nodes, e);
    return energy_from_knots(e);
}

/* fn (energy_one or energy_bound) of every individual of nodes (G, n, 2) into out (G,) */
static PyObject *population_map(PyObject *args, double (*fn)(const double *, const Energy *)) {
    PyObject *on, *oen, *oo;
    Energy e;
    EnergyBufs eb;
    Buf bn = {0}, bo = {0};
    memset(&eb, 0, sizeof(eb));
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
    if (energy_get(oen, &e, &eb, inner) < 0) goto done;
    const double *nodes = F64(bn);
    double *out = F64(bo);
    for (int64_t g = 0; g < g_count; g++) out[g] = fn(nodes + g * inner * 2, &e);
    ret = Py_NewRef(Py_None);
done:
    energy_release(&e, &eb);
    rel(&bn);
    rel(&bo);
    return ret;
}

/* population_energy(nodes, energy, out): the energy (G,) of nodes (G, n, 2) */
PyObject *py_population_energy(PyObject *self, PyObject *args) {
    return population_map(args, energy_one);
}

/* energy_bounds(nodes, energy, out): energy_bound (G,) of nodes (G, n, 2) (-1: no bound) */
PyObject *py_energy_bounds(PyObject *self, PyObject *args) {
    return population_map(args, energy_bound);
}

