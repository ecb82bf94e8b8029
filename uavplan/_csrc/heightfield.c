/* uavplan._ckernels: the terrain as a height field (uavplan.ground.HeightField), and exact
 * distances from points and segments to the two solids it bounds.
 *
 * The field is a lattice of points (the DEM's posts, each quad cut into s x s sub-quads on
 * the DEM's bilinear surface) at their true (x, y) in the field's frame (the site's ENU frame)
 * with their ground z. Each cell is cut into two triangles along the diagonal that puts them
 * on or above the bilinear patch (the "upper" surface: for z = a + b·u + c·v + d·u·v on the
 * unit square, the diagonal (0,0)-(1,1) when d >= 0, else (1,0)-(0,1); the plane of each
 * triangle then exceeds the patch by d·v·(1 - u) resp. -d·u·(1 - v) >= 0 and by at most
 * |d| / 4), or along the other one for the "lower" surface (on or below the patch). Both are
 * continuous triangulated surfaces (neighbouring cells share their edges).
 *
 *   kind 0, the ground:  the solid below the upper surface + lift
 *   kind 1, the ceiling: the solid above the lower surface + roof (roof = bounds.z max
 *                        above the ground + the margin; infinite: no ceiling)
 *
 * A route keeps the margin from both solids. The ceiling's solid is handled as the ground's
 * mirror image: z -> -z and heights h -> -h - roof turn "above the lower surface" into "below
 * the upper surface" (the twist changes sign, so does the diagonal), so one walk serves both.
 *
 * Distances are exact (closest points between a segment and a triangle, no iteration): the
 * minimum over the triangles near the segment, 0 when the segment meets a triangle or starts
 * inside the solid. The triangles near a segment are found by a walk over the lattice cells
 * within the search radius of it (a band along the segment, one row at a time): a leg costs
 * O(cells it passes over), and a cell whose highest corner is farther below the segment than
 * the radius is skipped on one comparison. Cells are located through an affine map from the
 * field's frame to lattice coordinates fitted to the lattice; ``slack`` (lattice units) bounds
 * how far a lattice point lies from where that map puts it, and widens every search. */
#include "kernels.h"

/* ------------------------------------------------------------------------------------------
 * Small vector algebra
 */

static inline double dot3(const double *a, const double *b) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

static inline void sub3(double *r, const double *a, const double *b) {
    r[0] = a[0] - b[0];
    r[1] = a[1] - b[1];
    r[2] = a[2] - b[2];
}

static inline void cross3(double *r, const double *a, const double *b) {
    r[0] = a[1] * b[2] - a[2] * b[1];
    r[1] = a[2] * b[0] - a[0] * b[2];
    r[2] = a[0] * b[1] - a[1] * b[0];
}

static inline void axpy3(double *r, const double *a, double t, const double *d) {
    r[0] = a[0] + t * d[0];
    r[1] = a[1] + t * d[1];
    r[2] = a[2] + t * d[2];
}

static inline double dist2(const double *a, const double *b) {
    double d[3];
    sub3(d, a, b);
    return dot3(d, d);
}

static inline double clamp01(double t) { return t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t); }

/* The point of triangle (a, b, c) closest to p (Ericson, Real-Time Collision Detection,
 * 5.1.5: by the Voronoi regions of its vertices, edges and face). */
static void closest_on_triangle(const double *p, const double *a, const double *b,
                                const double *c, double *q) {
    double ab[3], ac[3], ap[3], bp[3], cp[3];
    sub3(ab, b, a);
    sub3(ac, c, a);
    sub3(ap, p, a);
    double d1 = dot3(ab, ap), d2 = dot3(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        memcpy(q, a, 3 * sizeof(double));
        return;
    }
    sub3(bp, p, b);
    double d3 = dot3(ab, bp), d4 = dot3(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) {
        memcpy(q, b, 3 * sizeof(double));
        return;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        axpy3(q, a, d1 / (d1 - d3), ab);
        return;
    }
    sub3(cp, p, c);
    double d5 = dot3(ab, cp), d6 = dot3(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) {
        memcpy(q, c, 3 * sizeof(double));
        return;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        axpy3(q, a, d2 / (d2 - d6), ac);
        return;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) {
        double bc[3];
        sub3(bc, c, b);
        axpy3(q, b, (d4 - d3) / ((d4 - d3) + (d5 - d6)), bc);
        return;
    }
    double den = va + vb + vc;
    double v = vb / den, w = vc / den;
    for (int k = 0; k < 3; k++) q[k] = a[k] + ab[k] * v + ac[k] * w;
}

/* The closest points of segments p1-q1 and p2-q2 (Ericson 5.1.9); returns the squared
 * distance, and the point on the second segment in ``c2``. */
static double closest_segments(const double *p1, const double *q1, const double *p2,
                               const double *q2, double *c2) {
    double d1[3], d2[3], r[3], c1[3];
    sub3(d1, q1, p1);
    sub3(d2, q2, p2);
    sub3(r, p1, p2);
    double a = dot3(d1, d1), e = dot3(d2, d2), f = dot3(d2, r);
    double s, t;
    if (a <= 1e-24 && e <= 1e-24) {
        s = t = 0.0;
    } else if (a <= 1e-24) {
        s = 0.0;
        t = clamp01(f / e);
    } else {
        double c = dot3(d1, r);
        if (e <= 1e-24) {
            t = 0.0;
            s = clamp01(-c / a);
        } else {
            double b = dot3(d1, d2), den = a * e - b * b;
            s = den > 0.0 ? clamp01((b * f - c * e) / den) : 0.0;
            t = (b * s + f) / e;
            if (t < 0.0) {
                t = 0.0;
                s = clamp01(-c / a);
            } else if (t > 1.0) {
                t = 1.0;
                s = clamp01((b - c) / a);
            }
        }
    }
    axpy3(c1, p1, s, d1);
    axpy3(c2, p2, t, d2);
    return dist2(c1, c2);
}

/* Whether segment a-b meets triangle (p0, p1, p2) transversally (Moller-Trumbore with the
 * segment's parameter in [0, 1]); the meeting point in ``hit``. A segment in the triangle's
 * plane is left to the edge and end-point distances, which are then 0 where they touch. */
static int segment_meets_triangle(const double *a, const double *b, const double *p0,
                                  const double *p1, const double *p2, double *hit) {
    double e1[3], e2[3], d[3], h[3], s[3], q[3];
    sub3(e1, p1, p0);
    sub3(e2, p2, p0);
    sub3(d, b, a);
    cross3(h, d, e2);
    double det = dot3(e1, h);
    if (fabs(det) < 1e-300) return 0;
    double inv = 1.0 / det;
    sub3(s, a, p0);
    double u = inv * dot3(s, h);
    if (u < 0.0 || u > 1.0) return 0;
    cross3(q, s, e1);
    double v = inv * dot3(d, q);
    if (v < 0.0 || u + v > 1.0) return 0;
    double t = inv * dot3(e2, q);
    if (t < 0.0 || t > 1.0) return 0;
    axpy3(hit, a, t, d);
    return 1;
}

/* Exact distance between segment a-b (a == b: a point) and triangle t (3 corners, 9 values);
 * the triangle's closest point in ``near`` (may be NULL). */
static double segment_triangle_dist(const double *a, const double *b, const double *t,
                                    double *near) {
    const double *p0 = t, *p1 = t + 3, *p2 = t + 6;
    double q[3], best_q[3], best;
    int point = a[0] == b[0] && a[1] == b[1] && a[2] == b[2];
    if (!point && segment_meets_triangle(a, b, p0, p1, p2, q)) {
        if (near != NULL) memcpy(near, q, sizeof(q));
        return 0.0;
    }
    closest_on_triangle(a, p0, p1, p2, best_q);
    best = dist2(a, best_q);
    if (!point) {
        double d;
        closest_on_triangle(b, p0, p1, p2, q);
        if ((d = dist2(b, q)) < best) {
            best = d;
            memcpy(best_q, q, sizeof(q));
        }
        const double *edges[3][2] = {{p0, p1}, {p1, p2}, {p2, p0}};
        for (int k = 0; k < 3; k++) {
            if ((d = closest_segments(a, b, edges[k][0], edges[k][1], q)) < best) {
                best = d;
                memcpy(best_q, q, sizeof(q));
            }
        }
    }
    if (near != NULL) memcpy(near, best_q, sizeof(best_q));
    return sqrt(best);
}

/* ------------------------------------------------------------------------------------------
 * The lattice
 */

/* The height of surface ``kind`` at lattice point (i, j) (kind 1 mirrored: -z - roof). */
static inline double lat_h(const HField *f, int kind, int64_t i, int64_t j) {
    double z = f->z[i * f->nc + j];
    return kind == 0 ? z + f->lift : -z - f->roof;
}

/* The highest corner of cell (i, j) of surface ``kind``. */
static inline double cell_top(const HField *f, int kind, int64_t i, int64_t j) {
    const double *r0 = f->z + i * f->nc + j, *r1 = r0 + f->nc;
    if (kind == 0) return dmax(dmax(r0[0], r0[1]), dmax(r1[0], r1[1])) + f->lift;
    return -dmin(dmin(r0[0], r0[1]), dmin(r1[0], r1[1])) - f->roof;
}

/* The steepest slope of any triangle of cell (i, j) (either diagonal). */
static inline double cell_slope(const HField *f, int64_t i, int64_t j) {
    return f->slope[i * (f->nc - 1) + j];
}

/* The highest point of surface ``kind``. */
static inline double field_top(const HField *f, int kind) {
    return kind == 0 ? f->zmax + f->lift : -f->zmin - f->roof;
}

static inline void corner(const HField *f, int kind, int64_t i, int64_t j, double *p) {
    const double *q = f->xy + 2 * (i * f->nc + j);
    p[0] = q[0];
    p[1] = q[1];
    p[2] = lat_h(f, kind, i, j);
}

/* The two triangles (3 corners each) of cell (i, j) of surface ``kind``, on or above the
 * bilinear patch of its four corners. */
static void cell_triangles(const HField *f, int kind, int64_t i, int64_t j, double *t) {
    double p00[3], p01[3], p10[3], p11[3];
    corner(f, kind, i, j, p00);
    corner(f, kind, i, j + 1, p01);
    corner(f, kind, i + 1, j, p10);
    corner(f, kind, i + 1, j + 1, p11);
    const double *order[6];
    if (p00[2] + p11[2] - p01[2] - p10[2] >= 0.0) { /* the diagonal (i, j)-(i+1, j+1) */
        const double *o[6] = {p00, p01, p11, p00, p11, p10};
        memcpy(order, o, sizeof(o));
    } else { /* the diagonal (i, j+1)-(i+1, j) */
        const double *o[6] = {p00, p01, p10, p01, p11, p10};
        memcpy(order, o, sizeof(o));
    }
    for (int k = 0; k < 6; k++) memcpy(t + 3 * k, order[k], 3 * sizeof(double));
}

static inline void to_field(const HField *f, double x, double y, double *X, double *Y) {
    *X = f->ox + f->c * x - f->s * y;
    *Y = f->oy + f->s * x + f->c * y;
}

static inline void to_lattice(const HField *f, double X, double Y, double *u, double *v) {
    *u = f->aff[0] + f->aff[1] * X + f->aff[2] * Y;
    *v = f->aff[3] + f->aff[4] * X + f->aff[5] * Y;
}

static inline int64_t floor_in(double v, int64_t lo, int64_t hi) {
    if (!(v >= (double)lo)) return lo; /* NaN too */
    if (v >= (double)hi) return hi;
    return (int64_t)floor(v);
}

/* The height of triangle t over (X, Y) when (X, Y) lies in its outline (1), else 0. */
static int triangle_height(const double *t, double X, double Y, double *h) {
    double x0 = t[0], y0 = t[1], ex1 = t[3] - x0, ey1 = t[4] - y0, ex2 = t[6] - x0,
           ey2 = t[7] - y0;
    double det = ex1 * ey2 - ex2 * ey1;
    if (det == 0.0) return 0;
    double l1 = ((X - x0) * ey2 - ex2 * (Y - y0)) / det;
    double l2 = (ex1 * (Y - y0) - (X - x0) * ey1) / det;
    double l0 = 1.0 - l1 - l2;
    const double tol = -1e-9;
    if (l0 < tol || l1 < tol || l2 < tol) return 0;
    *h = l0 * t[2] + l1 * t[5] + l2 * t[8];
    return 1;
}

/* Surface ``kind``'s height over (X, Y) in the field's frame; NAN where the field does not
 * reach. */
static double surface_at(const HField *f, int kind, double X, double Y) {
    double u, v;
    to_lattice(f, X, Y, &u, &v);
    double s = f->slack + 1e-9;
    int64_t ncr = f->nr - 1, ncc = f->nc - 1;
    if (!(u >= -s && u <= (double)ncc + s && v >= -s && v <= (double)ncr + s)) return NAN;
    int64_t j0 = floor_in(u - s, 0, ncc - 1), j1 = floor_in(u + s, 0, ncc - 1);
    int64_t i0 = floor_in(v - s, 0, ncr - 1), i1 = floor_in(v + s, 0, ncr - 1);
    double t[18], h;
    for (int64_t i = i0; i <= i1; i++) {
        for (int64_t j = j0; j <= j1; j++) {
            cell_triangles(f, kind, i, j, t);
            if (triangle_height(t, X, Y, &h) || triangle_height(t + 9, X, Y, &h)) return h;
        }
    }
    return NAN;
}

/* The highest corner of surface ``kind`` over block (bi, bj) of FIELD_BLOCK x FIELD_BLOCK cells:
 * no cell of the block has a higher one (cell_top). */
static inline double block_top(const HField *f, int kind, int64_t bi, int64_t bj) {
    const double *bk = f->blk + 2 * (bi * f->nbc + bj);
    return kind == 0 ? bk[0] + f->lift : -bk[1] - f->roof;
}

/* A walk of segment a-b (field frame, z of kind 1 already mirrored) over the cells within
 * ``reach`` lattice units of its outline. */
typedef struct {
    const double *a, *b;
    double ua, va, du, dv, dz, reach;
    int64_t ncr, ncc;
} Walk;

/* The part [*t0, *t1] of the segment within ``reach`` of lattice rows [r0, r1] (their band
 * lo = r0 - reach .. hi = r1 + 1 + reach); 0 when it has none. */
static inline int band_t(const Walk *w, int64_t r0, int64_t r1, double *t0, double *t1) {
    double lo = (double)r0 - w->reach, hi = (double)(r1 + 1) + w->reach;
    *t0 = 0.0;
    *t1 = 1.0;
    if (fabs(w->dv) < 1e-300) return !(w->va < lo || w->va > hi);
    double u = (lo - w->va) / w->dv, v = (hi - w->va) / w->dv;
    if (u > v) {
        double tmp = u;
        u = v;
        v = tmp;
    }
    *t0 = dmax(u, 0.0);
    *t1 = dmin(v, 1.0);
    return *t0 <= *t1;
}

/* Row ``i`` of a walk, its cells in columns [jmin, jmax] (the whole row: 0, ncc - 1): each
 * cell whose highest corner lies within ``*best`` of the segment's stretch near it has its
 * triangles measured, ``*best`` lowered to any distance below it (the surface point to
 * ``near``, when not NULL). With ``skip``, a block of cells whose highest corner is clear of
 * the row's stretch by ``*best`` is passed over whole. Returns 1 when ``first`` and a
 * distance below ``*best`` was found (the walk stops there). */
static inline int walk_row(const HField *f, int kind, const Walk *w, int64_t i, int64_t jmin,
                           int64_t jmax, int skip, double *best, int first, double *near) {
    double t0, t1;
    if (!band_t(w, i, i, &t0, &t1)) return 0;
    const double *a = w->a, *b = w->b;
    double u0 = w->ua + t0 * w->du, u1 = w->ua + t1 * w->du;
    double umin = dmin(u0, u1) - w->reach, umax = dmax(u0, u1) + w->reach;
    if (umax < 0.0 || umin > (double)w->ncc) return 0;
    int64_t j0 = imax(floor_in(umin, 0, w->ncc - 1), jmin);
    int64_t j1 = imin(floor_in(umax, 0, w->ncc - 1), jmax);
    double zlo = dmin(a[2] + t0 * w->dz, a[2] + t1 * w->dz);
    double t[18], q[3];
    for (int64_t j = j0; j <= j1; j++) {
        if (skip && (j == j0 || j % FIELD_BLOCK == 0)) {
            /* a block whose highest corner is clear of this row's stretch by ``best``: each
             * of its cells would be skipped below, so skip them all */
            if (zlo - block_top(f, kind, i / FIELD_BLOCK, j / FIELD_BLOCK) >= *best) {
                j = imin(j1, (j / FIELD_BLOCK + 1) * FIELD_BLOCK - 1);
                continue;
            }
        }
        double top = cell_top(f, kind, i, j);
        if (zlo - top >= *best) continue;
        if (fabs(w->du) >= 1e-300) { /* the part of the row's stretch near this column */
            double c0 = ((double)j - w->reach - w->ua) / w->du;
            double c1 = ((double)(j + 1) + w->reach - w->ua) / w->du;
            double lo_t = dmax(t0, dmin(c0, c1)), hi_t = dmin(t1, dmax(c0, c1));
            if (lo_t > hi_t) continue;
            if (dmin(a[2] + lo_t * w->dz, a[2] + hi_t * w->dz) - top >= *best) continue;
        }
        cell_triangles(f, kind, i, j, t);
        for (int k = 0; k < 2; k++) {
            const double *tri = t + 9 * k;
            /* the triangle's plane is no farther than the triangle: both ends on one side of
             * it, at least ``best`` away, and the triangle is too */
            double e1[3], e2[3], nrm[3], pa[3], pb[3];
            sub3(e1, tri + 3, tri);
            sub3(e2, tri + 6, tri);
            cross3(nrm, e1, e2);
            sub3(pa, a, tri);
            sub3(pb, b, tri);
            double sa = dot3(pa, nrm), sb = dot3(pb, nrm);
            if (sa * sb > 0.0 && dmin(sa * sa, sb * sb) >= *best * *best * dot3(nrm, nrm))
                continue;
            double d = segment_triangle_dist(a, b, tri, q);
            if (d < *best) {
                *best = d;
                if (near != NULL) memcpy(near, q, sizeof(q));
                if (first) return 1;
            }
        }
    }
    return 0;
}

/* Sets up the walk of a-b within ``search``; 0 when no cell can be within it. */
static int walk_init(const HField *f, const double *a, const double *b, double search, Walk *w,
                     int64_t *i0, int64_t *i1) {
    if (!(search > 0.0)) return 0;
    double ub, vb;
    w->a = a;
    w->b = b;
    to_lattice(f, a[0], a[1], &w->ua, &w->va);
    to_lattice(f, b[0], b[1], &ub, &vb);
    w->ncr = f->nr - 1;
    w->ncc = f->nc - 1;
    w->reach = search * f->per_m + f->slack + 1e-9;
    double cap = (double)(w->ncr + w->ncc + 2);
    if (!(w->reach < cap)) w->reach = cap;
    w->du = ub - w->ua;
    w->dv = vb - w->va;
    w->dz = b[2] - a[2];
    *i0 = floor_in(dmin(w->va, vb) - w->reach, 0, w->ncr - 1);
    *i1 = floor_in(dmax(w->va, vb) + w->reach, 0, w->ncr - 1);
    return !(dmax(w->va, vb) + w->reach < 0.0 || dmin(w->va, vb) - w->reach > (double)w->ncr);
}

/* The smallest distance below ``search`` from segment a-b (field frame, z of kind 1 already
 * mirrored) to the triangles of surface ``kind``, or ``search`` when none is closer. The
 * closest surface point goes to ``near`` (may be NULL) when one was found. Walks the cells
 * within ``search`` of the segment's outline, row by row (so among equal distances the one
 * reported is always the same). */
static double surface_walk(const HField *f, int kind, const double *a, const double *b,
                           double search, double *near) {
    double best = search;
    Walk w;
    int64_t i0, i1;
    if (!walk_init(f, a, b, search, &w, &i0, &i1)) return best;
    for (int64_t i = i0; i <= i1; i++) walk_row(f, kind, &w, i, 0, w.ncc - 1, 1, &best, 0, near);
    return best;
}

/* Whether a triangle of surface ``kind`` lies within ``thr`` of segment a-b (field frame, z
 * of kind 1 mirrored): whether surface_walk would find a distance below ``thr``, found block by block. A
 * block of FIELD_BLOCK x FIELD_BLOCK cells whose highest corner is clear by ``thr`` of the
 * part of the segment near it is passed over whole: every cell of it would be skipped (its
 * corners are no higher, and the part of the segment near a cell lies within that part), so
 * the answer is surface_walk's; a long segment high over the ground looks at a few blocks
 * instead of hundreds of rows of cells. */
static int surface_near(const HField *f, int kind, const double *a, const double *b, double thr) {
    double best = thr;
    Walk w;
    int64_t i0, i1;
    if (!walk_init(f, a, b, thr, &w, &i0, &i1)) return 0;
    const int64_t B = FIELD_BLOCK;
    for (int64_t bi = i0 / B; bi <= i1 / B; bi++) {
        int64_t r0 = imax(i0, bi * B), r1 = imin(i1, bi * B + B - 1);
        double t0, t1;
        if (!band_t(&w, r0, r1, &t0, &t1)) continue;
        double u0 = w.ua + t0 * w.du, u1 = w.ua + t1 * w.du;
        double umin = dmin(u0, u1) - w.reach, umax = dmax(u0, u1) + w.reach;
        if (umax < 0.0 || umin > (double)w.ncc) continue;
        int64_t jb0 = floor_in(umin, 0, w.ncc - 1) / B, jb1 = floor_in(umax, 0, w.ncc - 1) / B;
        for (int64_t bj = jb0; bj <= jb1; bj++) {
            double lo_t = t0, hi_t = t1;
            if (fabs(w.du) >= 1e-300) { /* the part of the band's stretch near these columns */
                double c0 = ((double)(bj * B) - w.reach - w.ua) / w.du;
                double c1 = ((double)(bj * B + B) + w.reach - w.ua) / w.du;
                lo_t = dmax(t0, dmin(c0, c1));
                hi_t = dmin(t1, dmax(c0, c1));
                if (lo_t > hi_t) continue;
            }
            double zlo = dmin(a[2] + lo_t * w.dz, a[2] + hi_t * w.dz);
            if (zlo - block_top(f, kind, bi, bj) >= best) continue;
            int64_t jmax = imin(bj * B + B - 1, w.ncc - 1);
            for (int64_t i = r0; i <= r1; i++)
                if (walk_row(f, kind, &w, i, bj * B, jmax, 0, &best, 1, NULL)) return 1;
        }
    }
    return 0;
}

/* The segment's ends in the field's frame, z mirrored for the ceiling. */
static inline void ends_in(const HField *f, int kind, double ax, double ay, double az, double bx,
                           double by, double bz, double *a, double *b) {
    to_field(f, ax, ay, &a[0], &a[1]);
    to_field(f, bx, by, &b[0], &b[1]);
    a[2] = kind == 0 ? az : -az;
    b[2] = kind == 0 ? bz : -bz;
}

/* Interior points of a segment at most this many (a look along it before the walk) ... */
#define PROBE_POINTS 31
/* ... on a segment at least this long (lattice units) */
#define PROBE_MIN_CELLS 4.0

/* The k-th interior point along a segment, coarse to fine (1/2, 1/4, 3/4, 1/8, ...): the
 * first 2^m - 1 of them halve it evenly, and a hill the segment cuts through is met early. */
static inline double probe_t(int k) {
    int level = 0;
    while ((2 << level) - 1 <= k) level++;
    int first = (1 << level) - 1;   /* points before this level */
    int slot = 2 * (k - first) + 1; /* odd numerator at this level */
    return (double)slot / (double)(2 << level);
}

/* Whether a point along the segment a-b (field frame, kind's z) lies less than ``thr`` above
 * surface ``kind``: then the surface point below it is that close, and the segment is not
 * free (what the walk would find, sooner). Looked at for long segments only. */
static int probe_blocked(const HField *f, int kind, const double *a, const double *b,
                         double thr) {
    double ua, va, ub, vb;
    to_lattice(f, a[0], a[1], &ua, &va);
    to_lattice(f, b[0], b[1], &ub, &vb);
    double cells = dmax(fabs(ub - ua), fabs(vb - va));
    if (!(cells >= PROBE_MIN_CELLS)) return 0;
    int n = PROBE_POINTS;
    while (n > 1 && (double)n > cells) n = (n - 1) / 2; /* about one point a cell at most */
    for (int k = 0; k < n; k++) {
        double t = probe_t(k);
        double z = a[2] + t * (b[2] - a[2]);
        double h = surface_at(f, kind, a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
        if (z - h < thr - 1e-9) return 1; /* NaN (off the field): no */
    }
    return 0;
}

/* Whether the segment keeps ``thr`` from both solids (world frame). With ``probe``, a long
 * segment is first looked at in points along it (a cheap proof of "not free" for the long
 * chords a simplification tries; the answer is the same). */
int field_segment_free(const HField *f, double ax, double ay, double az, double bx, double by,
                       double bz, double thr, int probe) {
    for (int kind = 0; kind < 2; kind++) {
        if (kind == 1 && !(f->roof < INFINITY)) break;
        double a[3], b[3];
        ends_in(f, kind, ax, ay, az, bx, by, bz, a, b);
        double top = field_top(f, kind);
        if (dmin(a[2], b[2]) - top >= thr) continue;
        if (a[2] < top) {
            double h = surface_at(f, kind, a[0], a[1]);
            if (a[2] < h) return 0; /* starts inside the solid */
        }
        if (probe && probe_blocked(f, kind, a, b, thr)) return 0;
        if (surface_near(f, kind, a, b, thr)) return 0;
    }
    return 1;
}

/* The distance (capped at ``cap``) from the segment (world frame; a == b: a point) to the
 * nearer solid: which one in ``kind`` (-1: neither within ``cap``), the closest surface point
 * (x, y in the field's frame) in ``where`` (may be NULL). */
double field_segment_dist(const HField *f, double ax, double ay, double az, double bx, double by,
                          double bz, double cap, int *kind_out, double *where) {
    double best = cap;
    int which = -1;
    for (int kind = 0; kind < 2; kind++) {
        if (kind == 1 && !(f->roof < INFINITY)) break;
        double a[3], b[3], q[3];
        ends_in(f, kind, ax, ay, az, bx, by, bz, a, b);
        if (dmin(a[2], b[2]) - field_top(f, kind) >= best) continue;
        /* the height above the surface at either end bounds the distance from above */
        double search = best;
        const double *ends[2] = {a, b};
        for (int e = 0; e < 2; e++) {
            const double *p = ends[e];
            double h = surface_at(f, kind, p[0], p[1]);
            if (p[2] < h) { /* inside the solid */
                if (where != NULL) {
                    where[0] = p[0];
                    where[1] = p[1];
                }
                if (kind_out != NULL) *kind_out = kind;
                return 0.0;
            }
            if (p[2] - h < search) search = (p[2] - h) * (1.0 + 1e-12) + 1e-12;
        }
        double d = surface_walk(f, kind, a, b, search, q);
        if (d < search && d < best) {
            best = d;
            which = kind;
            if (where != NULL) {
                where[0] = q[0];
                where[1] = q[1];
            }
        }
    }
    if (kind_out != NULL) *kind_out = which;
    return best;
}

double field_point_dist(const HField *f, double x, double y, double z, double cap) {
    return field_segment_dist(f, x, y, z, x, y, z, cap, NULL, NULL);
}

/* the most levels of one column field_column measures exactly at once, and the most
 * triangles it gathers for them (more: each level walks on its own) */
#define COLUMN_LEVELS 256
#define COLUMN_TRIANGLES 2048

/* The exact distances from the points (X, Y, z of level need[i]) (field frame, kind 1 already
 * mirrored in the z below) to surface ``kind``, each looked for within search[i], lowered into
 * out[need[i]]: the triangles within ``radius`` of the column, gathered once, then measured
 * for every level (a plane too far is skipped). */
static void column_exact(const HField *f, int kind, double X, double Y, double z0, double dz,
                         const int64_t *need, const double *search, int64_t m, double radius,
                         double zlow, double *out) {
    if (m == 0) return;
    double u, v;
    to_lattice(f, X, Y, &u, &v);
    int64_t ncr = f->nr - 1, ncc = f->nc - 1;
    double reach = radius * f->per_m + f->slack + 1e-9;
    double tris[COLUMN_TRIANGLES * 9], normals[COLUMN_TRIANGLES * 4];
    int64_t nt = 0, overflow = 0;
    if (u + reach >= 0.0 && u - reach <= (double)ncc && v + reach >= 0.0 &&
        v - reach <= (double)ncr) {
        int64_t i0 = floor_in(v - reach, 0, ncr - 1), i1 = floor_in(v + reach, 0, ncr - 1);
        int64_t j0 = floor_in(u - reach, 0, ncc - 1), j1 = floor_in(u + reach, 0, ncc - 1);
        for (int64_t i = i0; i <= i1 && !overflow; i++) {
            for (int64_t j = j0; j <= j1; j++) {
                if (zlow - cell_top(f, kind, i, j) >= radius) continue;
                if (nt + 2 > COLUMN_TRIANGLES) {
                    overflow = 1;
                    break;
                }
                cell_triangles(f, kind, i, j, tris + 9 * nt);
                for (int k = 0; k < 2; k++, nt++) {
                    const double *t = tris + 9 * nt;
                    double e1[3], e2[3], *nrm = normals + 4 * nt;
                    sub3(e1, t + 3, t);
                    sub3(e2, t + 6, t);
                    cross3(nrm, e1, e2);
                    nrm[3] = dot3(nrm, nrm);
                }
            }
        }
    }
    for (int64_t l = 0; l < m; l++) {
        double p[3] = {X, Y, z0 + (double)need[l] * dz};
        if (kind == 1) p[2] = -p[2];
        double best = search[l];
        if (overflow) {
            best = surface_walk(f, kind, p, p, best, NULL);
        } else {
            for (int64_t t = 0; t < nt; t++) {
                const double *tri = tris + 9 * t, *nrm = normals + 4 * t;
                double pa[3], q[3];
                sub3(pa, p, tri);
                double sa = dot3(pa, nrm);
                if (sa * sa >= best * best * nrm[3]) continue; /* its plane is too far */
                closest_on_triangle(p, tri, tri + 3, tri + 6, q);
                double d = sqrt(dist2(p, q));
                if (d < best) best = d;
            }
        }
        if (best < out[need[l]]) out[need[l]] = best;
    }
}

/* Blocks of FIELD_BLOCK x FIELD_BLOCK cells: the highest corner of surface ``kind`` and the
 * steepest triangle in each (for field_column's bounds over a wide neighbourhood). */
int field_blocks_init(const HField *f, FieldBlocks *fb) {
    memset(fb, 0, sizeof(*fb));
    int64_t ncr = f->nr - 1, ncc = f->nc - 1;
    fb->nbr = (ncr + FIELD_BLOCK - 1) / FIELD_BLOCK;
    fb->nbc = (ncc + FIELD_BLOCK - 1) / FIELD_BLOCK;
    size_t n = (size_t)(fb->nbr * fb->nbc);
    fb->top = malloc(sizeof(double) * 2 * n);
    fb->slope = malloc(sizeof(double) * n);
    if (fb->top == NULL || fb->slope == NULL) {
        field_blocks_free(fb);
        PyErr_NoMemory();
        return -1;
    }
    for (size_t k = 0; k < n; k++) {
        fb->top[2 * k] = fb->top[2 * k + 1] = -INFINITY;
        fb->slope[k] = 0.0;
    }
    for (int64_t i = 0; i < ncr; i++) {
        for (int64_t j = 0; j < ncc; j++) {
            size_t k = (size_t)((i / FIELD_BLOCK) * fb->nbc + j / FIELD_BLOCK);
            fb->top[2 * k] = dmax(fb->top[2 * k], cell_top(f, 0, i, j));
            if (f->roof < INFINITY) fb->top[2 * k + 1] = dmax(fb->top[2 * k + 1], cell_top(f, 1, i, j));
            fb->slope[k] = dmax(fb->slope[k], cell_slope(f, i, j));
        }
    }
    return 0;
}

void field_blocks_free(FieldBlocks *fb) {
    free(fb->top);
    free(fb->slope);
    fb->top = fb->slope = NULL;
}

/* The distances from the points (x, y, z0 + k dz), k < n (world frame), to the field's solids
 * lowered into out[k] (pre-filled with the cap, or less: clearance_table's node columns).
 * Exact where below ``exact``; elsewhere possibly a lower bound (never above the distance, at
 * least ``exact``): with R the column's reach (the largest out[k]), G the steepest slope and T
 * the highest corner of the blocks of cells within R (``fb``), and H the height above the
 * surface, a surface point within R horizontally lies at least max(H / sqrt(1 + G^2), z - T)
 * away, and any other at least R. */
void field_column(const HField *f, const FieldBlocks *fb, double x, double y, double z0,
                  double dz, int64_t n, double *out, double exact) {
    double cap = 0.0;
    for (int64_t k = 0; k < n; k++) cap = dmax(cap, out[k]);
    for (int kind = 0; kind < 2; kind++) {
        if (kind == 1 && !(f->roof < INFINITY)) break;
        double X, Y, u, v;
        to_field(f, x, y, &X, &Y);
        double h = surface_at(f, kind, X, Y);
        to_lattice(f, X, Y, &u, &v);
        double reach = cap * f->per_m + f->slack + 1e-9;
        int64_t ncr = f->nr - 1, ncc = f->nc - 1;
        double top = -INFINITY, slope = 0.0;
        if (u + reach >= 0.0 && u - reach <= (double)ncc && v + reach >= 0.0 &&
            v - reach <= (double)ncr) {
            int64_t i0 = floor_in(v - reach, 0, ncr - 1) / FIELD_BLOCK;
            int64_t i1 = floor_in(v + reach, 0, ncr - 1) / FIELD_BLOCK;
            int64_t j0 = floor_in(u - reach, 0, ncc - 1) / FIELD_BLOCK;
            int64_t j1 = floor_in(u + reach, 0, ncc - 1) / FIELD_BLOCK;
            for (int64_t i = i0; i <= i1; i++) {
                for (int64_t j = j0; j <= j1; j++) {
                    top = dmax(top, fb->top[2 * (i * fb->nbc + j) + kind]);
                    slope = dmax(slope, fb->slope[i * fb->nbc + j]);
                }
            }
        }
        double shrink = 1.0 / sqrt(1.0 + slope * slope);
        /* the levels that need the exact distance, and how far to look for it */
        int64_t need[COLUMN_LEVELS];
        double search[COLUMN_LEVELS];
        int64_t m = 0, rest = -1;
        double radius = 0.0, zlow = INFINITY;
        for (int64_t k = 0; k < n; k++) {
            double z = z0 + (double)k * dz;
            if (kind == 1) z = -z;
            if (z < h) {
                out[k] = 0.0;
                continue;
            }
            double lower = z - top; /* farther than the cap from every triangle: as is */
            if (lower >= out[k]) continue;
            if (!isnan(h)) lower = dmax(lower, (z - h) * shrink);
            lower = dmin(lower, cap);
            if (lower >= exact) {
                if (lower < out[k]) out[k] = lower;
                continue;
            }
            double r = out[k];
            if (z - h < r) r = (z - h) * (1.0 + 1e-12) + 1e-12;
            if (m == COLUMN_LEVELS) { /* more than a column's buffer: walk for the rest */
                rest = k;
                break;
            }
            need[m] = k;
            search[m++] = r;
            radius = dmax(radius, r);
            zlow = dmin(zlow, z);
        }
        column_exact(f, kind, X, Y, z0, dz, need, search, m, radius, zlow, out);
        for (int64_t k = rest; rest >= 0 && k < n; k++) { /* (not reached for real grids) */
            double p[3] = {X, Y, z0 + (double)k * dz};
            if (kind == 1) p[2] = -p[2];
            if (p[2] < h) {
                out[k] = 0.0;
                continue;
            }
            double r = out[k];
            if (p[2] - h < r) r = (p[2] - h) * (1.0 + 1e-12) + 1e-12;
            double d = surface_walk(f, kind, p, p, r, NULL);
            if (d < out[k]) out[k] = d;
        }
    }
}

/* ------------------------------------------------------------------------------------------
 * Python wrappers (tests and messages; the planners reach the field through the world)
 */

/* field_heights(p (n, 2), W, kind, out (n,)): surface ``kind``'s z over world-frame points
 * (kind 0: the upper surface + lift; kind 1: the lower surface, without the roof); NaN where
 * the field does not reach or the world has none. */
PyObject *py_field_heights(PyObject *self, PyObject *args) {
    PyObject *op, *wt, *oo;
    int kind;
    Buf bp = {0}, bo = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOiO", &op, &wt, &kind, &oo)) return NULL;
    if (world_get(wt, &wb, 5) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(op, &bp, T_F64, 2, 0, "p") < 0 || get_buf(oo, &bo, T_F64, 1, 1, "out") < 0)
        goto done;
    Py_ssize_t n = dim(&bp, 0);
    if (need(dim(&bp, 1) == 2 && dim(&bo, 0) == n && (kind == 0 || kind == 1),
             "field_heights: p (n, 2), out (n,), kind 0 or 1") < 0)
        goto done;
    const HField *f = &wb.w.f;
    for (Py_ssize_t i = 0; i < n; i++) {
        double X, Y, h = NAN;
        if (f->present) {
            to_field(f, F64(bp)[2 * i], F64(bp)[2 * i + 1], &X, &Y);
            h = surface_at(f, kind, X, Y);
            if (kind == 1) h = -h - f->roof; /* back from the mirror: the lower surface */
        }
        F64(bo)[i] = h;
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&bp);
    rel(&bo);
    world_release(&wb);
    return ret;
}

/* field_nearest(p0 (n, 3), p1 (n, 3), W, dist (n,), kind (n,), where (n, 2)): each segment's
 * distance to the nearer of the field's solids (inf and kind -1: no field), which one, and
 * the closest surface point (x, y in the field's frame). */
PyObject *py_field_nearest(PyObject *self, PyObject *args) {
    PyObject *o0, *o1, *wt, *od, *ok, *ow;
    Buf b0 = {0}, b1 = {0}, bd = {0}, bk = {0}, bw = {0};
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "OOOOOO", &o0, &o1, &wt, &od, &ok, &ow)) return NULL;
    if (world_get(wt, &wb, 5) < 0) return NULL;
    PyObject *ret = NULL;
    if (get_buf(o0, &b0, T_F64, 2, 0, "p0") < 0 || get_buf(o1, &b1, T_F64, 2, 0, "p1") < 0 ||
        get_buf(od, &bd, T_F64, 1, 1, "dist") < 0 || get_buf(ok, &bk, T_I64, 1, 1, "kind") < 0 ||
        get_buf(ow, &bw, T_F64, 2, 1, "where") < 0)
        goto done;
    Py_ssize_t n = dim(&b0, 0);
    if (need(dim(&b0, 1) == 3 && dim(&b1, 1) == 3 && dim(&b1, 0) == n && dim(&bd, 0) == n &&
                 dim(&bk, 0) == n && dim(&bw, 0) == n && dim(&bw, 1) == 2,
             "field_nearest: p0, p1 (n, 3), dist, kind (n,), where (n, 2)") < 0)
        goto done;
    const HField *f = &wb.w.f;
    const double *p0 = F64(b0), *p1 = F64(b1);
    for (Py_ssize_t i = 0; i < n; i++) {
        int kind = -1;
        double where[2] = {NAN, NAN}, d = INFINITY;
        if (f->present)
            d = field_segment_dist(f, p0[3 * i], p0[3 * i + 1], p0[3 * i + 2], p1[3 * i],
                                   p1[3 * i + 1], p1[3 * i + 2], INFINITY, &kind, where);
        F64(bd)[i] = d;
        I64(bk)[i] = kind;
        F64(bw)[2 * i] = where[0];
        F64(bw)[2 * i + 1] = where[1];
    }
    ret = Py_NewRef(Py_None);
done:
    rel(&b0);
    rel(&b1);
    rel(&bd);
    rel(&bk);
    rel(&bw);
    world_release(&wb);
    return ret;
}
