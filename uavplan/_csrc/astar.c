/* uavplan._ckernels: the grid A* of uavplan/planners/astar.py (an indexed binary heap over
 * the nodes of a (column, y, z) grid, node clearances computed on demand). */
#include "kernels.h"

enum { A_FOUND = 0, A_NO_PATH = 1, A_INVALID_START = 2, A_INVALID_GOAL = 3 };

/* node indices in the search's table: int32 (a grid of more than 2**31 nodes is refused) */
typedef int32_t idx_t;
/* a node's state byte */
#define CLOSED 1
#define BLOCKED 2
#define LINKED 4

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
    if (w->f.present) best = field_point_dist(&w->f, px, py, pz, best); /* the terrain */
    return best;
}

PyObject *py_node_clearance(PyObject *self, PyObject *args) {
    double px, py, pz, cap;
    PyObject *wt;
    WorldBufs wb;
    if (!PyArg_ParseTuple(args, "dddOd", &px, &py, &pz, &wt, &cap)) return NULL;
    if (world_get(wt, &wb, 7) < 0) return NULL;
    double r = node_clearance(px, py, pz, &wb.w, cap);
    world_release(&wb);
    return PyFloat_FromDouble(r);
}

/* f = g + h is not stored: computed here, it is the very double the search used to store
 * (every f was set as g + h, the goal's with h = 0), so the order is unchanged */
static inline int before(idx_t a, idx_t b, const double *g, const double *h) {
    double fa = g[a] + h[a], fb = g[b] + h[b];
    if (fa != fb) return fa < fb;
    return h[a] < h[b];
}

static void sift_up(idx_t *heap, idx_t *pos, idx_t i, const double *g, const double *h) {
    idx_t v = heap[i];
    while (i > 0) {
        idx_t p = (i - 1) >> 1;
        if (!before(v, heap[p], g, h)) break;
        heap[i] = heap[p];
        pos[heap[i]] = i;
        i = p;
    }
    heap[i] = v;
    pos[v] = i;
}

static idx_t heap_pop(idx_t *heap, idx_t *pos, idx_t size, const double *g, const double *h) {
    idx_t top = heap[0];
    pos[top] = -1;
    size -= 1;
    if (size > 0) {
        idx_t v = heap[size];
        idx_t i = 0;
        for (;;) {
            idx_t c = 2 * i + 1;
            if (c >= size) break;
            if (c + 1 < size && before(heap[c + 1], heap[c], g, h)) c += 1;
            if (!before(heap[c], v, g, h)) break;
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
PyObject *py_astar_kernel(PyObject *self, PyObject *args) {
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
    if (need(n_nodes + 2 < (int64_t)INT32_MAX, "astar: more than 2**31 grid nodes") < 0)
        goto done;
    /* one block, ASTAR_NODE_BYTES a node: clear (n), g, h (n + 1) as doubles; parent, heap,
     * pos (n + 1) as int32; state (n + 1 bytes: 1 closed, 2 blocked, 4 linked to the goal) */
    mem = malloc(sizeof(double) * ((size_t)n_nodes + 2 * nn) + sizeof(idx_t) * 3 * nn + nn);
    if (mem == NULL) {
        PyErr_NoMemory();
        goto done;
    }
    double *clear = mem;
    double *g = clear + n_nodes;
    double *h = g + nn;
    idx_t *parent = (idx_t *)(h + nn);
    idx_t *heap = parent + nn;
    idx_t *pos = heap + nn;
    unsigned char *closed = (unsigned char *)(pos + nn);
    for (int64_t i = 0; i < n_nodes; i++) clear[i] = NAN;
    for (size_t i = 0; i < nn; i++) {
        g[i] = INFINITY;
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
    /* the goal's links (at most 343): kept apart, their nodes flagged */
    idx_t goal_node[343];
    double goal_cost[343];
    for (int64_t i = 0; i < n_goal; i++) {
        goal_node[i] = (idx_t)buf_node[i];
        goal_cost[i] = buf_cost[i];
        closed[buf_node[i]] |= LINKED;
    }
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
        parent[v] = (idx_t)start_id;
        heap[size] = (idx_t)v;
        size += 1;
        sift_up(heap, pos, (idx_t)(size - 1), g, h);
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
        int64_t u = heap_pop(heap, pos, (idx_t)size, g, h);
        size -= 1;
        if (u == goal_id) {
            found = 1;
            break;
        }
        closed[u] |= CLOSED;
        expanded += 1;
        double link = INFINITY;
        if (closed[u] & LINKED) {
            for (int64_t i = 0; i < n_goal; i++) {
                if (goal_node[i] == u) {
                    link = goal_cost[i];
                    break;
                }
            }
        }
        if (link < INFINITY && g[u] + link < g[goal_id]) {
            g[goal_id] = g[u] + link;
            parent[goal_id] = (idx_t)u;
            if (pos[goal_id] < 0) {
                heap[size] = (idx_t)goal_id;
                pos[goal_id] = (idx_t)size;
                size += 1;
            }
            sift_up(heap, pos, pos[goal_id], g, h);
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
            if (closed[v] & (CLOSED | BLOCKED)) continue;
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
                closed[v] |= BLOCKED;
                continue;
            }
            if (du + dv - mlen[m] < 2.0 * lim) {
                if (!segment_free(ux, uy, uz, vx, vy, vz, w, margin)) continue;
            }
            g[v] = ng;
            parent[v] = (idx_t)u;
            if (pos[v] < 0) {
                double ex = vx - gx;
                double ey = vy - gy;
                double ez = vz - gz;
                h[v] = k0 * sqrt(ex * ex + ey * ey + ez * ez) + k2 * fabs(ez);
                heap[size] = (idx_t)v;
                size += 1;
                sift_up(heap, pos, (idx_t)(size - 1), g, h);
            } else {
                sift_up(heap, pos, pos[v], g, h);
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

