/* uavplan._ckernels: the module. Its method table, and the constants the Python side reads
 * from it (uavplan.planners._kernels, uavplan.planners.proposal, uavplan._geom) instead of
 * writing them down a second time. */
#include "kernels.h"

#if !HAVE_THREADS
#pragma message("uavplan: this build has no helper threads: the SPSA step runs on one thread")
#endif

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
    {"field_heights", py_field_heights, METH_VARARGS, NULL},
    {"field_nearest", py_field_nearest, METH_VARARGS, NULL},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef moddef = {
    PyModuleDef_HEAD_INIT, "_ckernels",
    "Compiled kernels of uavplan (C; see uavplan/_csrc/kernels.h).", -1, methods, NULL, NULL,
    NULL, NULL,
};

/* The constants uavplan reads from here (it never writes them down again): the SPSA step's
 * switches, the proposals' draw kinds, the memo's size and probes, the step's thread limit
 * and whether this build has threads at all, the geometry's tolerances, and the fields of
 * every named structure (args.c). */
static int add_constants(PyObject *m) {
    static const struct {
        const char *name;
        long value;
    } ints[] = {
        {"SPSA_START_END", SPSA_START_END}, {"SPSA_LITERAL", SPSA_LITERAL},
        {"SPSA_POP_INDEX", SPSA_POP_INDEX}, {"SPSA_ESCAPE", SPSA_ESCAPE},
        {"SPSA_OSCILLATE", SPSA_OSCILLATE}, {"DRAW_NONE", DRAW_NONE},
        {"DRAW_UNIFORM", DRAW_UNIFORM},     {"DRAW_SYMMETRIC", DRAW_SYMMETRIC},
        {"DRAW_NORMAL", DRAW_NORMAL},       {"MEMO_BITS", MEMO_BITS},
        {"MEMO_PROBES", MEMO_PROBES},       {"STEP_MAX_THREADS", STEP_MAX_THREADS},
        {"HAVE_THREADS", HAVE_THREADS},     {"FIELD_META", FIELD_META},
        {"FIELD_BLOCK", FIELD_BLOCK},
    };
    static const struct {
        const char *name;
        double value;
    } reals[] = {{"SPSA_EPS", SPSA_EPS}, {"GOLD", GOLD}, {"DIST_TOL_M", DIST_TOL_M}, {"FAR", FAR}};
    for (size_t i = 0; i < sizeof(ints) / sizeof(ints[0]); i++)
        if (PyModule_AddIntConstant(m, ints[i].name, ints[i].value) < 0) return -1;
    for (size_t i = 0; i < sizeof(reals) / sizeof(reals[0]); i++) {
        PyObject *v = PyFloat_FromDouble(reals[i].value);
        if (v == NULL || PyModule_AddObject(m, reals[i].name, v) < 0) {
            Py_XDECREF(v);
            return -1;
        }
    }
    PyObject *fields = args_fields();
    if (fields == NULL || PyModule_AddObject(m, "FIELDS", fields) < 0) {
        Py_XDECREF(fields);
        return -1;
    }
    return 0;
}

PyMODINIT_FUNC PyInit__ckernels(void) {
    ziggurat_init();
    if (args_init() < 0) return NULL;
    PyObject *m = PyModule_Create(&moddef);
    if (m != NULL && add_constants(m) < 0) Py_CLEAR(m);
    return m;
}
