/* uavplan._ckernels: the per-individual random streams (splitmix64; normal draws by
 * Marsaglia & Tsang's ziggurat), and numpy's ±1 draws from the caller's bit generator. The
 * draws themselves are inline, in kernels.h. */
#include "kernels.h"

double ZKN[128], ZWN[128], ZFN[128];

void ziggurat_init(void) {
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

double randn_tail(uint64_t *st, double hz, int iz) {
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

/* ziggurat_tables() -> (kn, wn, fn) as tuples of floats (for tests) */
PyObject *py_ziggurat_tables(PyObject *self, PyObject *noargs) {
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
PyObject *py_stream_draws(PyObject *self, PyObject *args) {
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

/* sign_draws(capsule, out): out (float64, any shape) filled with ±1, 2·b − 1 for b the top bit
 * of each of the bit generator's next 32-bit draws; for numpy's Generator this is
 * 2.0 · rng.integers(0, 2, size) − 1.0 draw for draw (Lemire's bounded draw of {0, 1} keeps
 * the top bit of a 32-bit draw and never rejects), at a fraction of its cost. The caller holds
 * the bit generator's lock. */
PyObject *py_sign_draws(PyObject *self, PyObject *args) {
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

