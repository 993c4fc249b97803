/* mast_native: the Python face of the mast_core kernels (buffer protocol, no NumPy C API, so
 * the module does not depend on NumPy's ABI; the stable ABI of CPython 3.11).
 *
 *   init(log2_table)                                   the Q24 log2 table (fixedpoint.LOG2_TABLE)
 *   remap(image, map1, map2, x0, y0, out)              one rectified patch into out (h x w uint8)
 *   match(lefts, rights, xs, ys, maxds, preds, window, radius, cost_zssd, subpixel, noise_dn,
 *         min_ratio, max_sigma_px, status, ints, floats)   many points' match_point
 *   follow(prevs, curs, xs, ys, pdxs, pdys, window, radius, noise_dn, min_ratio, max_sigma_px,
 *          status, floats)                             many points' follow_point (parabola)
 *   imm_predict(x, p, mu, dt, q_quiet, q_manoeuvre, quiet_stay_s, manoeuvre_stay_s)
 *   imm_correct(x, p, mu, east_m, north_m, r)          one track's ground filter, in place
 *   imm_state(x, p, mu, xs, ps)                        its combined state into xs (4), ps (16)
 *
 * Arrays come in as buffers: images 2-D uint8 with unit column stride; the per-point inputs and
 * the outputs C-contiguous, of the item sizes stated at each function. */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>
#include "mast_core.h"

static int get(PyObject *obj, Py_buffer *view, int writable)
{
    return PyObject_GetBuffer(obj, view, (writable ? PyBUF_WRITABLE : 0) | PyBUF_RECORDS_RO);
}

/* a 2-D uint8 image with unit column stride */
static int get_image(PyObject *obj, Py_buffer *view, const char *what)
{
    if (get(obj, view, 0) < 0)
        return -1;
    if (view->ndim != 2 || view->itemsize != 1 || view->strides[1] != 1
        || (view->format && strcmp(view->format, "B") != 0)) {
        PyErr_Format(PyExc_ValueError, "%s must be a 2-D uint8 array with unit column stride", what);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

/* a contiguous array of n items of `itemsize` bytes (n < 0: any count, returned) */
static int get_flat(PyObject *obj, Py_buffer *view, Py_ssize_t itemsize, Py_ssize_t n, int writable,
                    const char *what)
{
    if (PyObject_GetBuffer(obj, view, (writable ? PyBUF_WRITABLE : 0) | PyBUF_C_CONTIGUOUS | PyBUF_FORMAT) < 0)
        return -1;
    if (view->itemsize != itemsize || (n >= 0 && view->len != n * itemsize)) {
        PyErr_Format(PyExc_ValueError, "%s must hold %zd items of %zd bytes", what, n, itemsize);
        PyBuffer_Release(view);
        return -1;
    }
    return 0;
}

static PyObject *py_init(PyObject *self, PyObject *arg)
{
    Py_buffer t;
    if (get_flat(arg, &t, 8, (1 << MC_LOG_TABLE_BITS) + 1, 0, "log2_table") < 0)
        return NULL;
    mc_set_log2_table((const int64_t *)t.buf);
    PyBuffer_Release(&t);
    Py_RETURN_NONE;
}

static PyObject *py_remap(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "remap(image, map1, map2, x0, y0, out)");
        return NULL;
    }
    Py_buffer img, m1, m2, out;
    long x0 = PyLong_AsLong(args[3]), y0 = PyLong_AsLong(args[4]);
    if (PyErr_Occurred())
        return NULL;
    if (get_image(args[0], &img, "image") < 0)
        return NULL;
    PyObject *res = NULL;
    Py_ssize_t h = img.shape[0], w = img.shape[1];
    if (get_flat(args[1], &m1, 2, h * w * 2, 0, "map1") < 0)
        goto done_img;
    if (get_flat(args[2], &m2, 2, h * w, 0, "map2") < 0)
        goto done_m1;
    if (get(args[5], &out, 1) < 0)
        goto done_m2;
    if (out.ndim != 2 || out.itemsize != 1 || out.strides[1] != 1 || out.strides[0] != out.shape[1]) {
        PyErr_SetString(PyExc_ValueError, "out must be a C-contiguous 2-D uint8 array");
        goto done_out;
    }
    mc_remap_patch((const uint8_t *)img.buf, img.strides[0], (int)w, (int)h, (const int16_t *)m1.buf,
                   (const uint16_t *)m2.buf, (int)x0, (int)y0, (int)out.shape[1], (int)out.shape[0],
                   (uint8_t *)out.buf);
    res = Py_None;
    Py_INCREF(res);
done_out:
    PyBuffer_Release(&out);
done_m2:
    PyBuffer_Release(&m2);
done_m1:
    PyBuffer_Release(&m1);
done_img:
    PyBuffer_Release(&img);
    return res;
}

/* the i-th images of two lists, as 2-D uint8 of one shape; 0, or -1 with an exception set;
 * 1: not usable (other dtype, shape, ...) -> the caller's reference path */
static int image_pair(PyObject *la, PyObject *lb, Py_ssize_t i, Py_buffer *a, Py_buffer *b)
{
    PyObject *oa = PySequence_GetItem(la, i), *ob = PySequence_GetItem(lb, i);
    int rc = -1;
    if (!oa || !ob)
        goto out;
    if (get(oa, a, 0) < 0) {
        PyErr_Clear();
        rc = 1;
        goto out;
    }
    if (get(ob, b, 0) < 0) {
        PyErr_Clear();
        PyBuffer_Release(a);
        rc = 1;
        goto out;
    }
    if (a->ndim != 2 || b->ndim != 2 || a->itemsize != 1 || b->itemsize != 1 || !a->format || !b->format
        || strcmp(a->format, "B") != 0 || strcmp(b->format, "B") != 0 || a->strides[1] != 1
        || b->strides[1] != 1 || a->shape[0] != b->shape[0] || a->shape[1] != b->shape[1]) {
        PyBuffer_Release(a);
        PyBuffer_Release(b);
        rc = 1;
        goto out;
    }
    rc = 0;
out:
    Py_XDECREF(oa);
    Py_XDECREF(ob);
    return rc;
}

static PyObject *py_match(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 16) {
        PyErr_SetString(PyExc_TypeError, "match(lefts, rights, xs, ys, maxds, preds, window, radius, "
                                         "cost_zssd, subpixel, noise_dn, min_ratio, max_sigma_px, "
                                         "status, ints, floats)");
        return NULL;
    }
    Py_ssize_t n = PySequence_Size(args[0]);
    if (n < 0 || PySequence_Size(args[1]) != n) {
        PyErr_SetString(PyExc_ValueError, "lefts and rights must be sequences of one length");
        return NULL;
    }
    mc_match_params p;
    p.window = (int)PyLong_AsLong(args[6]);
    int radius = (int)PyLong_AsLong(args[7]);
    p.cost_zssd = PyObject_IsTrue(args[8]);
    p.subpixel = (int)PyLong_AsLong(args[9]);
    p.noise_dn = PyFloat_AsDouble(args[10]);
    p.min_ratio = PyFloat_AsDouble(args[11]);
    p.max_sigma_px = PyFloat_AsDouble(args[12]);
    if (PyErr_Occurred())
        return NULL;
    Py_buffer bx, by, bd, bp, bs, bi, bf;
    PyObject *res = NULL;
    if (get_flat(args[2], &bx, 8, n, 0, "xs") < 0)
        return NULL;
    if (get_flat(args[3], &by, 8, n, 0, "ys") < 0)
        goto r_x;
    if (get_flat(args[4], &bd, 8, n, 0, "maxds") < 0)
        goto r_y;
    if (get_flat(args[5], &bp, 8, n, 0, "preds") < 0)
        goto r_d;
    if (get_flat(args[13], &bs, 4, n, 1, "status") < 0)
        goto r_p;
    if (get_flat(args[14], &bi, 8, 5 * n, 1, "ints") < 0)
        goto r_s;
    if (get_flat(args[15], &bf, 8, 3 * n, 1, "floats") < 0)
        goto r_i;
    const double *xs = bx.buf, *ys = by.buf, *preds = bp.buf;
    const int64_t *maxds = bd.buf;
    int32_t *status = bs.buf;
    int64_t *ints = bi.buf;
    double *floats = bf.buf;
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_buffer a, b;
        int rc = image_pair(args[0], args[1], i, &a, &b);
        if (rc < 0)
            goto r_f;
        mc_match_result r;
        memset(&r, 0, sizeof r);
        r.status = MC_MATCH_REFERENCE;
        if (rc == 0) {
            int has_pred = !isnan(preds[i]);
            long long maxd = maxds[i];
            if (maxd >= 0 && maxd < (1 << 20))
                mc_match_point(a.buf, a.strides[0], b.buf, b.strides[0], (int)a.shape[0], (int)a.shape[1],
                               xs[i], ys[i], (int)maxd, has_pred, preds[i], has_pred ? radius : -1, &p, &r);
            PyBuffer_Release(&a);
            PyBuffer_Release(&b);
        }
        status[i] = r.status;
        ints[5 * i] = r.value_q8;
        ints[5 * i + 1] = r.d_int;
        ints[5 * i + 2] = r.lo;
        ints[5 * i + 3] = r.hi;
        ints[5 * i + 4] = r.best_cost;
        floats[3 * i] = r.ratio;
        floats[3 * i + 1] = r.sigma_px;
        floats[3 * i + 2] = r.texture;
    }
    res = Py_None;
    Py_INCREF(res);
r_f:
    PyBuffer_Release(&bf);
r_i:
    PyBuffer_Release(&bi);
r_s:
    PyBuffer_Release(&bs);
r_p:
    PyBuffer_Release(&bp);
r_d:
    PyBuffer_Release(&bd);
r_y:
    PyBuffer_Release(&by);
r_x:
    PyBuffer_Release(&bx);
    return res;
}

static PyObject *py_follow(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 13) {
        PyErr_SetString(PyExc_TypeError, "follow(prevs, curs, xs, ys, pdxs, pdys, window, radius, noise_dn, "
                                         "min_ratio, max_sigma_px, status, floats)");
        return NULL;
    }
    Py_ssize_t n = PySequence_Size(args[0]);
    if (n < 0 || PySequence_Size(args[1]) != n) {
        PyErr_SetString(PyExc_ValueError, "prevs and curs must be sequences of one length");
        return NULL;
    }
    int window = (int)PyLong_AsLong(args[6]), radius = (int)PyLong_AsLong(args[7]);
    double noise = PyFloat_AsDouble(args[8]), min_ratio = PyFloat_AsDouble(args[9]);
    double max_sigma = PyFloat_AsDouble(args[10]);
    if (PyErr_Occurred())
        return NULL;
    Py_buffer bx, by, bu, bv, bs, bf;
    PyObject *res = NULL;
    if (get_flat(args[2], &bx, 8, n, 0, "xs") < 0)
        return NULL;
    if (get_flat(args[3], &by, 8, n, 0, "ys") < 0)
        goto r_x;
    if (get_flat(args[4], &bu, 8, n, 0, "pdxs") < 0)
        goto r_y;
    if (get_flat(args[5], &bv, 8, n, 0, "pdys") < 0)
        goto r_u;
    if (get_flat(args[11], &bs, 4, n, 1, "status") < 0)
        goto r_v;
    if (get_flat(args[12], &bf, 8, 8 * n, 1, "floats") < 0)
        goto r_s;
    const double *xs = bx.buf, *ys = by.buf, *pdx = bu.buf, *pdy = bv.buf;
    int32_t *status = bs.buf;
    double *f = bf.buf;
    for (Py_ssize_t i = 0; i < n; i++) {
        Py_buffer a, b;
        int rc = image_pair(args[0], args[1], i, &a, &b);
        if (rc < 0)
            goto r_f;
        mc_follow_result r;
        memset(&r, 0, sizeof r);
        r.status = MC_FOLLOW_REFERENCE;
        if (rc == 0) {
            mc_follow_point(a.buf, a.strides[0], b.buf, b.strides[0], (int)a.shape[0], (int)a.shape[1], xs[i],
                            ys[i], pdx[i], pdy[i], window, radius, noise, min_ratio, max_sigma, &r);
            PyBuffer_Release(&a);
            PyBuffer_Release(&b);
        }
        status[i] = r.status;
        double *o = f + 8 * i;
        o[0] = r.x_px; o[1] = r.y_px; o[2] = r.dx_px; o[3] = r.dy_px;
        o[4] = r.cost; o[5] = r.sigma_x_px; o[6] = r.sigma_y_px; o[7] = r.ratio;
    }
    res = Py_None;
    Py_INCREF(res);
r_f:
    PyBuffer_Release(&bf);
r_s:
    PyBuffer_Release(&bs);
r_v:
    PyBuffer_Release(&bv);
r_u:
    PyBuffer_Release(&bu);
r_y:
    PyBuffer_Release(&by);
r_x:
    PyBuffer_Release(&bx);
    return res;
}

/* float64 C-contiguous buffers of a track's IMM: x (8), p (32), mu (2) */
static int imm_buffers(PyObject *const *args, Py_buffer *bx, Py_buffer *bp, Py_buffer *bm)
{
    if (get_flat(args[0], bx, 8, 8, 1, "x") < 0)
        return -1;
    if (get_flat(args[1], bp, 8, 32, 1, "p") < 0) {
        PyBuffer_Release(bx);
        return -1;
    }
    if (get_flat(args[2], bm, 8, 2, 1, "mu") < 0) {
        PyBuffer_Release(bx);
        PyBuffer_Release(bp);
        return -1;
    }
    return 0;
}

static void imm_release(Py_buffer *bx, Py_buffer *bp, Py_buffer *bm)
{
    PyBuffer_Release(bx);
    PyBuffer_Release(bp);
    PyBuffer_Release(bm);
}

static PyObject *py_imm_predict(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 8) {
        PyErr_SetString(PyExc_TypeError, "imm_predict(x, p, mu, dt, q_quiet, q_manoeuvre, quiet_stay_s, "
                                         "manoeuvre_stay_s)");
        return NULL;
    }
    double dt = PyFloat_AsDouble(args[3]), q[2] = {PyFloat_AsDouble(args[4]), PyFloat_AsDouble(args[5])};
    double stay0 = PyFloat_AsDouble(args[6]), stay1 = PyFloat_AsDouble(args[7]);
    if (PyErr_Occurred())
        return NULL;
    Py_buffer bx, bp, bm;
    if (imm_buffers(args, &bx, &bp, &bm) < 0)
        return NULL;
    mc_imm_predict(bx.buf, bp.buf, bm.buf, dt, q, stay0, stay1);
    imm_release(&bx, &bp, &bm);
    Py_RETURN_NONE;
}

static PyObject *py_imm_correct(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 6) {
        PyErr_SetString(PyExc_TypeError, "imm_correct(x, p, mu, east_m, north_m, r)");
        return NULL;
    }
    double z[2] = {PyFloat_AsDouble(args[3]), PyFloat_AsDouble(args[4])};
    if (PyErr_Occurred())
        return NULL;
    Py_buffer bx, bp, bm, br;
    if (get_flat(args[5], &br, 8, 4, 0, "r") < 0)
        return NULL;
    if (imm_buffers(args, &bx, &bp, &bm) < 0) {
        PyBuffer_Release(&br);
        return NULL;
    }
    mc_imm_correct(bx.buf, bp.buf, bm.buf, z, br.buf);
    imm_release(&bx, &bp, &bm);
    PyBuffer_Release(&br);
    Py_RETURN_NONE;
}

static PyObject *py_imm_state(PyObject *self, PyObject *const *args, Py_ssize_t nargs)
{
    if (nargs != 5) {
        PyErr_SetString(PyExc_TypeError, "imm_state(x, p, mu, xs, ps)");
        return NULL;
    }
    Py_buffer bx, bp, bm, bxs, bps;
    if (imm_buffers(args, &bx, &bp, &bm) < 0)
        return NULL;
    PyObject *res = NULL;
    if (get_flat(args[3], &bxs, 8, 4, 1, "xs") < 0)
        goto out;
    if (get_flat(args[4], &bps, 8, 16, 1, "ps") < 0) {
        PyBuffer_Release(&bxs);
        goto out;
    }
    mc_imm_state(bx.buf, bp.buf, bm.buf, bxs.buf, bps.buf);
    PyBuffer_Release(&bxs);
    PyBuffer_Release(&bps);
    res = Py_None;
    Py_INCREF(res);
out:
    imm_release(&bx, &bp, &bm);
    return res;
}

static PyMethodDef methods[] = {
    {"init", (PyCFunction)py_init, METH_O, "init(log2_table): the Q24 log2 table (1025 int64)"},
    {"remap", (PyCFunction)(void (*)(void))py_remap, METH_FASTCALL, "remap(image, map1, map2, x0, y0, out)"},
    {"match", (PyCFunction)(void (*)(void))py_match, METH_FASTCALL, "many points' match_point"},
    {"follow", (PyCFunction)(void (*)(void))py_follow, METH_FASTCALL, "many points' follow_point"},
    {"imm_predict", (PyCFunction)(void (*)(void))py_imm_predict, METH_FASTCALL, "GroundTrack._predict"},
    {"imm_correct", (PyCFunction)(void (*)(void))py_imm_correct, METH_FASTCALL, "GroundTrack's model updates"},
    {"imm_state", (PyCFunction)(void (*)(void))py_imm_state, METH_FASTCALL, "GroundTrack.state"},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {PyModuleDef_HEAD_INIT, "mast_native",
                                    "The mast-stereo pipeline's compiled per-track kernels (native/).", -1,
                                    methods};

PyMODINIT_FUNC PyInit_mast_native(void) { return PyModule_Create(&module); }
