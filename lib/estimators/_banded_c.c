/* Compiled kernels of the smoothing spline (sportfusion.estimators.spline) and of the block-tridiagonal
 * solves (sportfusion.estimators.blocktri), as a C extension: the fast path.
 *
 * Each kernel mirrors a numpy function, named in its comment block below; those stay the readable reference,
 * the fallback where this extension is not built (setup.py builds it as optional; the numpy path is
 * slower, docs/speed.md) and what the tests compare it with (tests/test_banded_native.py,
 * tests/test_fast_paths.py, tests/test_blocktri.py).  The spline's kernels: the Reinsch solve (banded
 * LDL^T, several right-hand sides; spline._reinsch), the central bands of B^-1 (spline._ldl_inverse_bands_py),
 * diag((W + K)^-1) (spline._minv_diag_py), the spline's evaluation (NaturalCubicSpline.evaluate) and arc
 * length (NaturalCubicSpline.arc_length); the robust screen's running median (spline_robust._running_median_py).
 *
 * Arrays travel through the buffer protocol (no numpy headers needed to build): the Python
 * wrappers in _banded.py pass C-contiguous float64 (or complex128) arrays and preallocated outputs.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <complex.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

/* ---- buffers ------------------------------------------------------------------------------ */

typedef struct {
    Py_buffer view;
    int held;
} Buf;

/* a C-contiguous buffer of float64 ("d") or complex128 ("Zd") items, native byte order */
static int get_view(PyObject *obj, Buf *b, int writable) {
    int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
    b->held = 0;
    if (PyObject_GetBuffer(obj, &b->view, flags) < 0) return -1;
    b->held = 1;
    const char *f = b->view.format ? b->view.format : "B";
    if (*f == '@' || *f == '=' || (PY_LITTLE_ENDIAN && *f == '<')) f++;
    if (strcmp(f, "d") != 0 && strcmp(f, "Zd") != 0) {
        PyErr_Format(PyExc_TypeError, "expected float64 or complex128 items, got format '%s'", b->view.format);
        return -1;
    }
    return 0;
}

static int get_buf(PyObject *obj, Buf *b, Py_ssize_t itemsize, Py_ssize_t count, int writable, const char *name) {
    if (get_view(obj, b, writable) < 0) return -1;
    if (b->view.itemsize != itemsize || b->view.len != itemsize * count) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd items of %zd bytes, got %zd bytes", name, count, itemsize,
                     b->view.len);
        return -1;
    }
    return 0;
}

static void release(Buf *bufs, int k) {
    for (int i = 0; i < k; i++)
        if (bufs[i].held) PyBuffer_Release(&bufs[i].view);
}

/* ---- the banded pieces, for a real (double) or complex symmetric (double complex) B ------- */

/* Bands of B = R + alpha Q^T W^{-1} Q (m = n - 2 interior knots): diagonal a0, a1[j] = B[j+1, j],
 * a2[j] = B[j+2, j] (zero at the end), as spline._reinsch_bands. */
#define DEFINE_BANDS(NAME, T)                                                                                      \
    static void NAME(const double *h, const double *ih, const T *winv, double alpha, Py_ssize_t m, T *a0, T *a1,   \
                     T *a2) {                                                                                      \
        for (Py_ssize_t j = 0; j < m; j++) {                                                                       \
            double q0 = ih[j], q2 = ih[j + 1], q1 = -(q0 + q2);                                                    \
            a0[j] = (h[j] + h[j + 1]) / 3.0 +                                                                      \
                    alpha * (winv[j] * q0 * q0 + winv[j + 1] * q1 * q1 + winv[j + 2] * q2 * q2);                   \
            a1[j] = 0.0;                                                                                           \
            a2[j] = 0.0;                                                                                           \
            if (j + 1 < m) {                                                                                       \
                double q0n = ih[j + 1], q1n = -(q0n + ih[j + 2]);                                                  \
                a1[j] = h[j + 1] / 6.0 + alpha * (winv[j + 1] * q1 * q0n + winv[j + 2] * q2 * q1n);                \
            }                                                                                                      \
            if (j + 2 < m) a2[j] = alpha * winv[j + 2] * q2 * ih[j + 2];                                           \
        }                                                                                                          \
    }

/* LDL^T of the pentadiagonal B without pivoting, in place: a0 -> d, a1 -> l1 (L[i+1, i]),
 * a2 -> l2 (L[i+2, i]); as spline._ldl_inverse_bands_py (its first loop). */
#define DEFINE_LDL(NAME, T)                                                                                        \
    static void NAME(Py_ssize_t m, T *d, T *l1, T *l2) {                                                           \
        for (Py_ssize_t i = 0; i < m; i++) {                                                                       \
            T di = d[i];                                                                                           \
            if (i >= 1) di -= l1[i - 1] * l1[i - 1] * d[i - 1];                                                    \
            if (i >= 2) di -= l2[i - 2] * l2[i - 2] * d[i - 2];                                                    \
            d[i] = di;                                                                                             \
            if (i + 1 < m) {                                                                                       \
                T v = l1[i];                                                                                       \
                if (i >= 1) v -= l2[i - 1] * l1[i - 1] * d[i - 1];                                                 \
                l1[i] = v / di;                                                                                    \
            } else {                                                                                               \
                l1[i] = 0.0;                                                                                       \
            }                                                                                                      \
            l2[i] = (i + 2 < m) ? l2[i] / di : 0.0;                                                                \
        }                                                                                                          \
    }

/* Central bands of Z = B^{-1} from the LDL^T factors (Hutchinson-de Hoog / Takahashi recursion):
 * z0[i] = Z[i, i], z1[i] = Z[i, i+1], z2[i] = Z[i, i+2]; each array has m + 2 entries (zero tail). */
#define DEFINE_INV(NAME, T)                                                                                        \
    static void NAME(Py_ssize_t m, const T *d, const T *l1, const T *l2, T *z0, T *z1, T *z2) {                    \
        z0[m] = z0[m + 1] = z1[m] = z1[m + 1] = z2[m] = z2[m + 1] = 0.0;                                           \
        for (Py_ssize_t i = m - 1; i >= 0; i--) {                                                                  \
            T a = l1[i], b = l2[i];                                                                                \
            z2[i] = -a * z1[i + 1] - b * z0[i + 2];                                                                \
            z1[i] = -a * z0[i + 1] - b * z1[i + 1];                                                                \
            z0[i] = 1.0 / d[i] - a * z1[i] - b * z2[i];                                                            \
        }                                                                                                          \
    }

/* diag((W + K)^{-1}) = winv - alpha winv^2 diag(Q Z Q^T), as spline._minv_diag_py (spline._qzqt_diag_py).
 * Row i of diag(Q Z Q^T) needs Z's bands at interior rows i-2 .. i only, so it is formed inside the
 * backward recursion (row i + 2 once Z's row i is known) from a rolling window: no Z arrays. */
#define DEFINE_MINV(NAME, T, BANDS, LDL)                                                                           \
    static T NAME##_row(const double *ih, Py_ssize_t n, Py_ssize_t i, T z0i, T z0i1, T z0i2, T z1i1, T z1i2,       \
                        T z2i2) {                                                                                  \
        /* z0i = Z[i, i] (interior knot i + 1), z0i1 = Z[i-1, i-1], z0i2 = Z[i-2, i-2], z1i1 = Z[i-1, i],          \
         * z1i2 = Z[i-2, i-1], z2i2 = Z[i-2, i] */                                                                 \
        double ca = (i <= n - 3) ? ih[i] : 0.0;                                                                    \
        double cb = (i >= 1 && i <= n - 2) ? -(ih[i - 1] + ih[i]) : 0.0;                                           \
        double cc = (i >= 2) ? ih[i - 1] : 0.0;                                                                    \
        T acc = 0.0;                                                                                               \
        if (ca != 0.0) acc += ca * ca * z0i;                                                                       \
        if (cb != 0.0) {                                                                                           \
            acc += cb * cb * z0i1;                                                                                 \
            if (ca != 0.0) acc += 2 * ca * cb * z1i1;                                                              \
        }                                                                                                          \
        if (cc != 0.0) {                                                                                           \
            acc += cc * cc * z0i2;                                                                                 \
            if (cb != 0.0) acc += 2 * cb * cc * z1i2;                                                              \
            if (ca != 0.0) acc += 2 * ca * cc * z2i2;                                                              \
        }                                                                                                          \
        return acc;                                                                                                \
    }                                                                                                              \
    /* from the LDL^T factors (d, l1, l2) of B and the inverse spacings ih */                                  \
    static void NAME##_factored(const double *ih, const T *winv, double alpha, Py_ssize_t n, const T *d,          \
                                const T *l1, const T *l2, T *out) {                                                \
        Py_ssize_t m = n - 2;                                                                                      \
        /* Z's row i (z0 diagonal, z1, z2 super-diagonals) and rows i+1 (z0_1, z1_1), i+2 (z0_2) */                \
        T z0_1 = 0.0, z0_2 = 0.0, z1_1 = 0.0;                                                                      \
        for (Py_ssize_t i = m - 1; i >= -2; i--) {                                                                 \
            T z0 = 0.0, z1 = 0.0, z2 = 0.0;                                                                        \
            if (i >= 0) {                                                                                          \
                T a = l1[i], b = l2[i];                                                                            \
                z2 = -a * z1_1 - b * z0_2;                                                                         \
                z1 = -a * z0_1 - b * z1_1;                                                                         \
                z0 = 1.0 / d[i] - a * z1 - b * z2;                                                                 \
            }                                                                                                      \
            /* output row r = i + 2 (interior rows r, r-1, r-2 of Z are i + 2, i + 1, i) */                      \
            Py_ssize_t r = i + 2;                                                                                  \
            if (r <= n - 1) {                                                                                      \
                T acc = NAME##_row(ih, n, r, z0_2, z0_1, z0, z1_1, z1, z2);                                        \
                out[r] = winv[r] - alpha * winv[r] * winv[r] * acc;                                                \
            }                                                                                                      \
            z0_2 = z0_1;                                                                                           \
            z0_1 = z0;                                                                                             \
            z1_1 = z1;                                                                                             \
        }                                                                                                          \
    }                                                                                                              \
    static int NAME(const double *h, const T *winv, double alpha, Py_ssize_t n, T *out) {                          \
        Py_ssize_t m = n - 2;                                                                                      \
        T *work = (T *)malloc(sizeof(T) * (size_t)(3 * m + 1));                                                    \
        double *ih = (double *)malloc(sizeof(double) * (size_t)(n - 1));                                           \
        if (!work || !ih) {                                                                                        \
            free(work);                                                                                            \
            free(ih);                                                                                              \
            return -1;                                                                                             \
        }                                                                                                          \
        for (Py_ssize_t i = 0; i < n - 1; i++) ih[i] = 1.0 / h[i];                                                 \
        T *d = work, *l1 = d + m, *l2 = l1 + m;                                                                    \
        BANDS(h, ih, winv, alpha, m, d, l1, l2);                                                                   \
        LDL(m, d, l1, l2);                                                                                         \
        NAME##_factored(ih, winv, alpha, n, d, l1, l2, out);                                                       \
        free(work);                                                                                                \
        free(ih);                                                                                                  \
        return 0;                                                                                                  \
    }

typedef double complex cdouble;
DEFINE_BANDS(bands_r, double)
DEFINE_BANDS(bands_c, cdouble)
DEFINE_LDL(ldl_r, double)
DEFINE_LDL(ldl_c, cdouble)
DEFINE_INV(inv_r, double)
DEFINE_INV(inv_c, cdouble)
DEFINE_MINV(minv_r, double, bands_r, ldl_r)
DEFINE_MINV(minv_c, cdouble, bands_c, ldl_c)

/* ---- Python entry points ------------------------------------------------------------------- */

static const char doc_inverse_bands[] =
    "inverse_bands(a0, a1, a2, z0, z1, z2)\n\n"
    "Central bands of B^{-1} for a symmetric pentadiagonal B (float64 or complex128, all length m):\n"
    "a0 diagonal, a1[i] = B[i+1, i], a2[i] = B[i+2, i]; z0, z1, z2 (length m + 2, written) get\n"
    "Z[i, i], Z[i, i+1], Z[i, i+2].  Returns False when a pivot of LDL^T is zero or not finite.";

static PyObject *py_inverse_bands(PyObject *self, PyObject *args) {
    PyObject *o[6];
    int complex_;
    if (!PyArg_ParseTuple(args, "pOOOOOO", &complex_, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5])) return NULL;
    Buf b[6];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    Py_ssize_t isz = complex_ ? (Py_ssize_t)sizeof(cdouble) : (Py_ssize_t)sizeof(double);
    if (get_view(o[0], &b[0], 0) < 0) goto done;
    Py_ssize_t m = b[0].view.len / isz;
    for (int k = 1; k < 6; k++)
        if (get_buf(o[k], &b[k], isz, k < 3 ? m : m + 2, k >= 3, "inverse_bands") < 0) goto done;
    if (b[0].view.itemsize != isz) {
        PyErr_SetString(PyExc_ValueError, "inverse_bands: a0 has the wrong item size");
        goto done;
    }
    int ok = 1;
    Py_BEGIN_ALLOW_THREADS;
    if (complex_) {
        cdouble *w = (cdouble *)malloc(sizeof(cdouble) * (size_t)(3 * m + 1));
        if (w) {
            for (Py_ssize_t i = 0; i < m; i++) {
                w[i] = ((cdouble *)b[0].view.buf)[i];
                w[m + i] = ((cdouble *)b[1].view.buf)[i];
                w[2 * m + i] = ((cdouble *)b[2].view.buf)[i];
            }
            ldl_c(m, w, w + m, w + 2 * m);
            for (Py_ssize_t i = 0; i < m; i++)
                if (!isfinite(creal(w[i])) || !isfinite(cimag(w[i])) || w[i] == 0.0) ok = 0;
            inv_c(m, w, w + m, w + 2 * m, b[3].view.buf, b[4].view.buf, b[5].view.buf);
            free(w);
        } else {
            ok = -1;
        }
    } else {
        double *w = (double *)malloc(sizeof(double) * (size_t)(3 * m + 1));
        if (w) {
            for (Py_ssize_t i = 0; i < m; i++) {
                w[i] = ((double *)b[0].view.buf)[i];
                w[m + i] = ((double *)b[1].view.buf)[i];
                w[2 * m + i] = ((double *)b[2].view.buf)[i];
            }
            ldl_r(m, w, w + m, w + 2 * m);
            for (Py_ssize_t i = 0; i < m; i++)
                if (!isfinite(w[i]) || w[i] == 0.0) ok = 0;
            inv_r(m, w, w + m, w + 2 * m, b[3].view.buf, b[4].view.buf, b[5].view.buf);
            free(w);
        } else {
            ok = -1;
        }
    }
    Py_END_ALLOW_THREADS;
    if (ok < 0) {
        PyErr_NoMemory();
        goto done;
    }
    res = PyBool_FromLong(ok);
done:
    release(b, 6);
    return res;
}

static const char doc_minv_diag[] =
    "minv_diag(complex, h, winv, alpha, out)\n\n"
    "diag((W + K)^{-1}), K = alpha Q R^{-1} Q^T, in O(n): h (n-1,) float64 knot spacings [s], winv (n,)\n"
    "1/w (float64, or complex128 with complex=True), out (n,) of winv's type, written.";

static PyObject *py_minv_diag(PyObject *self, PyObject *args) {
    PyObject *oh, *ow, *oo;
    double alpha;
    int complex_;
    if (!PyArg_ParseTuple(args, "pOOdO", &complex_, &oh, &ow, &alpha, &oo)) return NULL;
    Buf b[3];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    if (get_view(oh, &b[0], 0) < 0) goto done;
    Py_ssize_t n = b[0].view.len / (Py_ssize_t)sizeof(double) + 1;
    Py_ssize_t isz = complex_ ? (Py_ssize_t)sizeof(cdouble) : (Py_ssize_t)sizeof(double);
    if (b[0].view.itemsize != (Py_ssize_t)sizeof(double) || n < 3) {
        PyErr_SetString(PyExc_ValueError, "minv_diag: h must be float64 with at least 2 entries");
        goto done;
    }
    if (get_buf(ow, &b[1], isz, n, 0, "minv_diag winv") < 0 || get_buf(oo, &b[2], isz, n, 1, "minv_diag out") < 0)
        goto done;
    int st;
    Py_BEGIN_ALLOW_THREADS;
    st = complex_ ? minv_c(b[0].view.buf, b[1].view.buf, alpha, n, b[2].view.buf)
                  : minv_r(b[0].view.buf, b[1].view.buf, alpha, n, b[2].view.buf);
    Py_END_ALLOW_THREADS;
    if (st < 0) {
        PyErr_NoMemory();
        goto done;
    }
    res = Py_NewRef(Py_None);
done:
    release(b, 3);
    return res;
}

static const char doc_reinsch[] =
    "reinsch(h, winv, alpha, y, g, gam, mdiag)\n\n"
    "Knot values g and second derivatives gam (both (n, d) float64, written) of the smoothing spline\n"
    "through y (n, d) with weights 1/winv and penalty alpha: (R + alpha Q^T W^-1 Q) gam = Q^T y by a\n"
    "banded LDL^T, g = y - alpha W^-1 Q gam.  Returns False (nothing usable written) when a pivot is\n"
    "not positive and finite (the caller then solves the KKT system).  mdiag: None, or an (n,) float64\n"
    "array that gets diag((W + K)^-1) from the same factorization (GCV's trace: one factorization per score).";

static PyObject *py_reinsch(PyObject *self, PyObject *args) {
    PyObject *oh, *ow, *oy, *og, *oc, *om;
    double alpha;
    if (!PyArg_ParseTuple(args, "OOdOOOO", &oh, &ow, &alpha, &oy, &og, &oc, &om)) return NULL;
    Buf b[6];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    if (get_view(oh, &b[0], 0) < 0) goto done;
    Py_ssize_t n = b[0].view.len / (Py_ssize_t)sizeof(double) + 1;
    if (b[0].view.itemsize != (Py_ssize_t)sizeof(double) || n < 3) {
        PyErr_SetString(PyExc_ValueError, "reinsch: h must be float64 with at least 2 entries");
        goto done;
    }
    if (get_buf(ow, &b[1], sizeof(double), n, 0, "reinsch winv") < 0) goto done;
    if (get_view(oy, &b[2], 0) < 0) goto done;
    Py_ssize_t d = b[2].view.len / (Py_ssize_t)sizeof(double) / n;
    if (b[2].view.itemsize != (Py_ssize_t)sizeof(double) || d < 1 || b[2].view.len != (Py_ssize_t)sizeof(double) * n * d) {
        PyErr_SetString(PyExc_ValueError, "reinsch: y must be float64 (n, d)");
        goto done;
    }
    if (get_buf(og, &b[3], sizeof(double), n * d, 1, "reinsch g") < 0 ||
        get_buf(oc, &b[4], sizeof(double), n * d, 1, "reinsch gam") < 0)
        goto done;
    if (om != Py_None && get_buf(om, &b[5], sizeof(double), n, 1, "reinsch mdiag") < 0) goto done;
    const double *h = b[0].view.buf, *winv = b[1].view.buf, *y = b[2].view.buf;
    double *g = b[3].view.buf, *gam = b[4].view.buf, *mdiag = b[5].held ? b[5].view.buf : NULL;
    Py_ssize_t m = n - 2;
    int ok = 1;
    double *w = (double *)malloc(sizeof(double) * (size_t)(3 * m + n));
    if (!w) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS;
    double *dd = w, *l1 = w + m, *l2 = w + 2 * m, *ih = w + 3 * m;
    for (Py_ssize_t i = 0; i < n - 1; i++) ih[i] = 1.0 / h[i];
    bands_r(h, ih, winv, alpha, m, dd, l1, l2);
    ldl_r(m, dd, l1, l2);
    for (Py_ssize_t i = 0; i < m; i++)
        if (!(dd[i] > 0.0) || !isfinite(dd[i])) ok = 0;
    if (ok) {
        /* right-hand side Q^T y, then L z = rhs, z /= d, L^T x = z; x is gamma at the interior knots */
        for (Py_ssize_t k = 0; k < d; k++) gam[k] = gam[(n - 1) * d + k] = 0.0;
        for (Py_ssize_t j = 0; j < m; j++) {
            const double *y0 = y + j * d, *y1 = y0 + d, *y2 = y1 + d;
            double *z = gam + (j + 1) * d;
            for (Py_ssize_t k = 0; k < d; k++) {
                double v = (y2[k] - y1[k]) * ih[j + 1] - (y1[k] - y0[k]) * ih[j];
                if (j >= 1) v -= l1[j - 1] * z[k - d];
                if (j >= 2) v -= l2[j - 2] * z[k - 2 * d];
                z[k] = v;
            }
        }
        for (Py_ssize_t j = m - 1; j >= 0; j--) {
            double *x = gam + (j + 1) * d, r = 1.0 / dd[j];
            for (Py_ssize_t k = 0; k < d; k++) {
                double v = x[k] * r;
                if (j + 1 < m) v -= l1[j] * x[k + d];
                if (j + 2 < m) v -= l2[j] * x[k + 2 * d];
                x[k] = v;
            }
        }
        /* g = y - alpha winv (Q gamma): (Q gamma)_i = s_i - s_{i-1}, s_k = (gam[k+1] - gam[k]) / h[k] */
        for (Py_ssize_t i = 0; i < n; i++) {
            for (Py_ssize_t k = 0; k < d; k++) {
                double q = 0.0;
                if (i < n - 1) q += (gam[(i + 1) * d + k] - gam[i * d + k]) * ih[i];
                if (i > 0) q -= (gam[i * d + k] - gam[(i - 1) * d + k]) * ih[i - 1];
                g[i * d + k] = y[i * d + k] - alpha * q * winv[i];
            }
        }
        if (mdiag) minv_r_factored(ih, winv, alpha, n, dd, l1, l2, mdiag);
    }
    Py_END_ALLOW_THREADS;
    free(w);
    res = PyBool_FromLong(ok);
done:
    release(b, 6);
    return res;
}

/* index k of the knot interval [t[k], t[k+1]] holding x (largest k with t[k] <= x, clipped to 0..n-2) */
static Py_ssize_t interval(const double *t, Py_ssize_t n, double x) {
    Py_ssize_t lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (t[mid] <= x)
            lo = mid;
        else
            hi = mid;
    }
    if (lo > n - 2) lo = n - 2;
    return lo < 0 ? 0 : lo;
}

/* the interval of x, starting from the previous one (sorted queries walk forward) */
static Py_ssize_t walk(const double *t, Py_ssize_t n, Py_ssize_t k, double x) {
    if (k < n - 2 && t[k] <= x && x < t[k + 1]) return k;
    if (k + 1 < n - 1 && t[k + 1] <= x && (k + 2 >= n - 1 || x < t[k + 2])) return k + 1;
    return interval(t, n, x);
}

static const char doc_evaluate[] =
    "evaluate(t, g, c, tq, val, d1, d2, columns)\n\n"
    "Value, first and second derivative of the natural cubic spline (knots t (n,) [s], values g and\n"
    "second derivatives c, both (n, d)) at tq (m,) [s] into val, d1, d2 (float64, written): (m, d)\n"
    "row-major, or (d, m) with columns=True (each coordinate contiguous, as the output table wants it);\n"
    "a straight line beyond the end knots.  Same formulas as NaturalCubicSpline.evaluate.";

static PyObject *py_evaluate(PyObject *self, PyObject *args) {
    PyObject *o[7];
    int columns;
    if (!PyArg_ParseTuple(args, "OOOOOOOp", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &columns)) return NULL;
    Buf b[7];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    for (int k = 0; k < 4; k++) {
        if (get_view(o[k], &b[k], 0) < 0) goto done;
        if (b[k].view.itemsize != (Py_ssize_t)sizeof(double)) {
            PyErr_SetString(PyExc_ValueError, "evaluate: float64 arrays expected");
            goto done;
        }
    }
    Py_ssize_t n = b[0].view.len / (Py_ssize_t)sizeof(double), m = b[3].view.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t d = n ? b[1].view.len / (Py_ssize_t)sizeof(double) / n : 0;
    if (n < 2 || d < 1 || b[1].view.len != b[2].view.len || b[1].view.len != (Py_ssize_t)sizeof(double) * n * d) {
        PyErr_SetString(PyExc_ValueError, "evaluate: t (n >= 2,), g and c (n, d) expected");
        goto done;
    }
    for (int k = 4; k < 7; k++)
        if (get_buf(o[k], &b[k], sizeof(double), m * d, 1, "evaluate output") < 0) goto done;
    const double *t = b[0].view.buf, *g = b[1].view.buf, *c = b[2].view.buf, *tq = b[3].view.buf;
    double *val = b[4].view.buf, *d1 = b[5].view.buf, *d2 = b[6].view.buf;
    Py_BEGIN_ALLOW_THREADS;
    Py_ssize_t k = 0;
    for (Py_ssize_t i = 0; i < m; i++) {
        double x = tq[i];
        k = walk(t, n, k, x);
        double h = t[k + 1] - t[k];
        double bb = (x - t[k]) / h;
        if (bb < 0.0)
            bb = 0.0;
        else if (bb > 1.0)
            bb = 1.0;
        double a = 1.0 - bb;
        int out_lo = x < t[0], out_hi = x > t[n - 1];
        for (Py_ssize_t j = 0; j < d; j++) {
            Py_ssize_t o_ = columns ? j * m + i : i * d + j;
            double g0 = g[k * d + j], g1 = g[(k + 1) * d + j], c0 = c[k * d + j], c1 = c[(k + 1) * d + j];
            double s1 = (g1 - g0) / h - (3 * a * a - 1) * h / 6.0 * c0 + (3 * bb * bb - 1) * h / 6.0 * c1;
            d1[o_] = s1;
            if (out_lo) {
                val[o_] = g[j] + s1 * (x - t[0]);
                d2[o_] = 0.0;
            } else if (out_hi) {
                val[o_] = g[(n - 1) * d + j] + s1 * (x - t[n - 1]);
                d2[o_] = 0.0;
            } else {
                val[o_] = a * g0 + bb * g1 + ((a * a * a - a) * c0 + (bb * bb * bb - bb) * c1) * h * h / 6.0;
                d2[o_] = a * c0 + bb * c1;
            }
        }
    }
    Py_END_ALLOW_THREADS;
    res = Py_NewRef(Py_None);
done:
    release(b, 7);
    return res;
}

/* |S'(x)| on knot interval k (x clipped into it) */
static double speed(const double *t, const double *g, const double *c, Py_ssize_t d, Py_ssize_t k, double x) {
    double h = t[k + 1] - t[k];
    double bb = (x - t[k]) / h;
    if (bb < 0.0)
        bb = 0.0;
    else if (bb > 1.0)
        bb = 1.0;
    double a = 1.0 - bb, s = 0.0;
    for (Py_ssize_t j = 0; j < d; j++) {
        double v = (g[(k + 1) * d + j] - g[k * d + j]) / h - (3 * a * a - 1) * h / 6.0 * c[k * d + j] +
                   (3 * bb * bb - 1) * h / 6.0 * c[(k + 1) * d + j];
        s += v * v;
    }
    return sqrt(s);
}

static const char doc_arc_length[] =
    "arc_length(t, g, c, tq, xg, wg, out)\n\n"
    "Curvilinear distance [m] along the spline from t[0] to each tq (out (m,) float64, written): the\n"
    "speed |S'| integrated by Gauss-Legendre (nodes xg, weights wg on [-1, 1]) on every knot interval\n"
    "and on the partial interval up to tq.  Same sums as NaturalCubicSpline.arc_length.";

static PyObject *py_arc_length(PyObject *self, PyObject *args) {
    PyObject *o[7];
    if (!PyArg_ParseTuple(args, "OOOOOOO", &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6])) return NULL;
    Buf b[7];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    for (int k = 0; k < 6; k++) {
        if (get_view(o[k], &b[k], 0) < 0) goto done;
        if (b[k].view.itemsize != (Py_ssize_t)sizeof(double)) {
            PyErr_SetString(PyExc_ValueError, "arc_length: float64 arrays expected");
            goto done;
        }
    }
    Py_ssize_t n = b[0].view.len / (Py_ssize_t)sizeof(double), m = b[3].view.len / (Py_ssize_t)sizeof(double);
    Py_ssize_t d = n ? b[1].view.len / (Py_ssize_t)sizeof(double) / n : 0;
    Py_ssize_t nq = b[4].view.len / (Py_ssize_t)sizeof(double);
    if (n < 2 || d < 1 || b[1].view.len != b[2].view.len || b[1].view.len != (Py_ssize_t)sizeof(double) * n * d ||
        b[5].view.len != b[4].view.len) {
        PyErr_SetString(PyExc_ValueError, "arc_length: t (n >= 2,), g and c (n, d), xg and wg alike expected");
        goto done;
    }
    if (get_buf(o[6], &b[6], sizeof(double), m, 1, "arc_length out") < 0) goto done;
    const double *t = b[0].view.buf, *g = b[1].view.buf, *c = b[2].view.buf, *tq = b[3].view.buf;
    const double *xg = b[4].view.buf, *wg = b[5].view.buf;
    double *out = b[6].view.buf;
    double *cum = (double *)malloc(sizeof(double) * (size_t)n);
    if (!cum) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS;
    cum[0] = 0.0;
    for (Py_ssize_t k = 0; k < n - 1; k++) {
        double mid = 0.5 * (t[k] + t[k + 1]), half = 0.5 * (t[k + 1] - t[k]), acc = 0.0;
        for (Py_ssize_t q = 0; q < nq; q++) acc += wg[q] * speed(t, g, c, d, k, mid + half * xg[q]);
        cum[k + 1] = cum[k] + half * acc;
    }
    Py_ssize_t k = 0;
    for (Py_ssize_t i = 0; i < m; i++) {
        k = walk(t, n, k, tq[i]);
        double a = t[k];
        if (tq[i] == a) { /* a row on a knot: the interval's partial integral is zero */
            out[i] = cum[k];
            continue;
        }
        double mid = 0.5 * (a + tq[i]), half = 0.5 * (tq[i] - a), acc = 0.0;
        for (Py_ssize_t q = 0; q < nq; q++) acc += wg[q] * speed(t, g, c, d, k, mid + half * xg[q]);
        out[i] = cum[k] + half * acc;
    }
    Py_END_ALLOW_THREADS;
    free(cum);
    res = Py_NewRef(Py_None);
done:
    release(b, 7);
    return res;
}

/* ---- the running median of the robust screen (sportfusion.estimators.spline_robust) ----------- */

/* running_median: out[i] = the median of the values v[j] that are not NaN, |j - i| <= half, 0 <= j < n (NaN
 * where there is none; an even count takes the mean of the two middle values); as
 * spline_robust._running_median_py (numpy's nanmedian of the NaN-padded sliding windows).  The window's values
 * are kept sorted in s (2 half + 1 entries): each step finds the leaving value by bisection and moves the
 * entering one from its slot to its rank (as many moves as the ranks differ), O(n half) at most. */
static Py_ssize_t rm_find(const double *s, Py_ssize_t cnt, double x) { /* first index with s[k] >= x */
    Py_ssize_t lo = 0, hi = cnt;
    while (lo < hi) {
        Py_ssize_t mid = (lo + hi) / 2;
        if (s[mid] < x)
            lo = mid + 1;
        else
            hi = mid;
    }
    return lo;
}

static void running_median(const double *v, Py_ssize_t n, Py_ssize_t half, double *s, double *out) {
    Py_ssize_t cnt = 0;
    for (Py_ssize_t i = -half; i < n; i++) {
        Py_ssize_t in = i + half, gone = i - half - 1;
        int drop = gone >= 0 && !isnan(v[gone]), add = in < n && !isnan(v[in]);
        if (drop && add) { /* the new value takes the old one's slot, then moves to its rank */
            Py_ssize_t k = rm_find(s, cnt, v[gone]);
            double x = v[in];
            while (k + 1 < cnt && s[k + 1] < x) {
                s[k] = s[k + 1];
                k++;
            }
            while (k > 0 && s[k - 1] > x) {
                s[k] = s[k - 1];
                k--;
            }
            s[k] = x;
        } else if (drop) { /* the value leaving the window (an equal one: the same value) */
            Py_ssize_t k = rm_find(s, cnt, v[gone]);
            memmove(s + k, s + k + 1, sizeof(double) * (size_t)(cnt - k - 1));
            cnt--;
        } else if (add) {
            Py_ssize_t k = rm_find(s, cnt, v[in]);
            memmove(s + k + 1, s + k, sizeof(double) * (size_t)(cnt - k));
            s[k] = v[in];
            cnt++;
        }
        if (i >= 0) out[i] = cnt == 0 ? NAN : (cnt & 1) ? s[cnt / 2] : (s[cnt / 2 - 1] + s[cnt / 2]) / 2.0;
    }
}

static const char doc_running_median[] =
    "running_median(v, half, out)\n\n"
    "out[i] (float64 (n,), written) = the median of the non-NaN v[j] (float64 (n,)) with |j - i| <= half\n"
    "(the window shrinks at the ends; NaN where it holds no value), as numpy's nanmedian of the NaN-padded\n"
    "sliding windows.";

static PyObject *py_running_median(PyObject *self, PyObject *args) {
    PyObject *ov, *oo;
    Py_ssize_t half;
    if (!PyArg_ParseTuple(args, "OnO", &ov, &half, &oo)) return NULL;
    if (half < 0) {
        PyErr_SetString(PyExc_ValueError, "running_median: half must be >= 0");
        return NULL;
    }
    Buf b[2];
    memset(b, 0, sizeof b);
    PyObject *res = NULL;
    if (get_view(ov, &b[0], 0) < 0) goto done;
    Py_ssize_t n = b[0].view.len / (Py_ssize_t)sizeof(double);
    if (b[0].view.itemsize != (Py_ssize_t)sizeof(double)) {
        PyErr_SetString(PyExc_ValueError, "running_median: v must be float64");
        goto done;
    }
    if (get_buf(oo, &b[1], sizeof(double), n, 1, "running_median out") < 0) goto done;
    double *s = (double *)malloc(sizeof(double) * (size_t)(2 * half + 2));
    if (!s) {
        PyErr_NoMemory();
        goto done;
    }
    Py_BEGIN_ALLOW_THREADS;
    running_median(b[0].view.buf, n, half, s, b[1].view.buf);
    Py_END_ALLOW_THREADS;
    free(s);
    res = Py_NewRef(Py_None);
done:
    release(b, 2);
    return res;
}

/* ---- block-tridiagonal SPD systems (sportfusion.estimators.blocktri) ------------------------- */

/* bt_factor / bt_solve / bt_diag_inverse: blocktri.factor, solve and diagonal_of_inverse by block Cholesky.
 * Their numpy reference is the same functions without this extension: odd-even cyclic reduction (batched b x b
 * products, O(log n) array operations) and its selected inversion -- the same system solved in another order
 * of elimination, equal to rounding (tests/test_blocktri.py runs both against dense linear algebra on the same
 * inputs). */

/* A with diagonal blocks D_k and A[k, k+1] = E_k (b x b, row-major) as A = L L^T, L block lower bidiagonal
 * with diagonal blocks L_k (lower Cholesky factors of the Schur complements S_k = D_k - W_k-1^T W_k-1) and
 * sub-diagonal blocks W_k^T, W_k = L_k^-1 E_k.  Sequential, O(n b^3). */
#define BT_MAX 32

static int bt_chol(double *a, int b) { /* lower Cholesky in place (the upper part zeroed); -1: not PD */
    for (int j = 0; j < b; j++) {
        double d = a[j * b + j];
        for (int k = 0; k < j; k++) d -= a[j * b + k] * a[j * b + k];
        if (!(d > 0.0)) return -1;
        d = sqrt(d);
        a[j * b + j] = d;
        for (int i = j + 1; i < b; i++) {
            double v = a[i * b + j];
            for (int k = 0; k < j; k++) v -= a[i * b + k] * a[j * b + k];
            a[i * b + j] = v / d;
        }
        for (int i = 0; i < j; i++) a[i * b + j] = 0.0;
    }
    return 0;
}

/* The triangular solves and products below run with the right-hand sides' columns (q) innermost: independent
   sums side by side (vectorised) instead of one chain of dependent ones after another.  Each element still
   subtracts or adds the same products in the same order (k or j ascending), so the results are those of the
   element-by-element loops to the bit. */
static void bt_fwd(const double *l, int b, double *x, int c) { /* x <- L^-1 x, x (b x c) */
    for (int i = 0; i < b; i++) {
        double *xi = x + i * c;
        for (int k = 0; k < i; k++) {
            const double a = l[i * b + k], *xk = x + k * c;
            for (int q = 0; q < c; q++) xi[q] -= a * xk[q];
        }
        const double d = l[i * b + i];
        for (int q = 0; q < c; q++) xi[q] /= d;
    }
}

static void bt_bwd(const double *l, int b, double *x, int c) { /* x <- L^-T x, x (b x c) */
    for (int i = b - 1; i >= 0; i--) {
        double *xi = x + i * c;
        for (int k = i + 1; k < b; k++) {
            const double a = l[k * b + i], *xk = x + k * c;
            for (int q = 0; q < c; q++) xi[q] -= a * xk[q];
        }
        const double d = l[i * b + i];
        for (int q = 0; q < c; q++) xi[q] /= d;
    }
}

/* returns -1, or the first block whose Schur complement is not positive definite */
static Py_ssize_t bt_factor(Py_ssize_t n, int b, const double *d, const double *e, double *l, double *w) {
    const int bb = b * b;
    for (Py_ssize_t k = 0; k < n; k++) {
        double *lk = l + k * bb;
        if (lk != d + k * bb) memcpy(lk, d + k * bb, bb * sizeof(double)); /* l may be d itself (in place) */
        if (k > 0) { /* S_k = D_k - W^T W (lower triangle used) */
            const double *wp = w + (k - 1) * bb;
            for (int i = 0; i < b; i++)
                for (int j = 0; j <= i; j++) {
                    double v = 0.0;
                    for (int q = 0; q < b; q++) v += wp[q * b + i] * wp[q * b + j];
                    lk[i * b + j] -= v;
                }
        }
        if (bt_chol(lk, b) < 0) return k;
        if (k + 1 < n) {
            if (w != e) memcpy(w + k * bb, e + k * bb, bb * sizeof(double)); /* w may be e itself */
            bt_fwd(lk, b, w + k * bb, b);
        }
    }
    return -1;
}

/* x (b x c) -= M y, M (b x b) read as m[i * si + j * sj]: (si, sj) = (b, 1) for W, (1, b) for W^T */
static void bt_sub_prod(int b, int c, const double *m, int si, int sj, const double *y, double *x) {
    enum { CH = 16 }; /* the sums of up to CH columns at a time */
    double v[CH];
    for (int i = 0; i < b; i++)
        for (int q0 = 0; q0 < c; q0 += CH) {
            const int nq = c - q0 < CH ? c - q0 : CH;
            for (int q = 0; q < nq; q++) v[q] = 0.0;
            for (int j = 0; j < b; j++) {
                const double a = m[i * si + j * sj], *yj = y + j * c + q0;
                for (int q = 0; q < nq; q++) v[q] += a * yj[q];
            }
            for (int q = 0; q < nq; q++) x[i * c + q0 + q] -= v[q];
        }
}

static void bt_solve(Py_ssize_t n, int b, int c, const double *l, const double *w, double *x) {
    const int bb = b * b, bc = b * c;
    for (Py_ssize_t k = 0; k < n; k++) { /* y_k = L_k^-1 (r_k - W_k-1^T y_k-1) */
        double *xk = x + k * bc;
        if (k > 0) bt_sub_prod(b, c, w + (k - 1) * bb, 1, b, xk - bc, xk);
        bt_fwd(l + k * bb, b, xk, c);
    }
    for (Py_ssize_t k = n - 1; k >= 0; k--) { /* x_k = L_k^-T (y_k - W_k x_k+1) */
        double *xk = x + k * bc;
        if (k + 1 < n) bt_sub_prod(b, c, w + k * bb, b, 1, xk + bc, xk);
        bt_bwd(l + k * bb, b, xk, c);
    }
}

/* the diagonal blocks of A^-1: G_n-1 = S_n-1^-1, G_k = L_k^-T (I + W_k G_k+1 W_k^T) L_k^-1 */
static void bt_diag_inverse(Py_ssize_t n, int b, const double *l, const double *w, double *g) {
    const int bb = b * b;
    double li[BT_MAX * BT_MAX], m[BT_MAX * BT_MAX], t[BT_MAX * BT_MAX];
    for (Py_ssize_t k = n - 1; k >= 0; k--) {
        for (int i = 0; i < bb; i++) li[i] = 0.0;
        for (int i = 0; i < b; i++) li[i * b + i] = 1.0;
        bt_fwd(l + k * bb, b, li, b); /* L_k^-1 */
        for (int i = 0; i < bb; i++) m[i] = 0.0;
        for (int i = 0; i < b; i++) m[i * b + i] = 1.0;
        if (k + 1 < n) { /* m = I + W_k G_k+1 W_k^T */
            const double *wk = w + k * bb, *gn = g + (k + 1) * bb;
            for (int i = 0; i < b; i++)
                for (int j = 0; j < b; j++) {
                    double v = 0.0;
                    for (int q = 0; q < b; q++) v += wk[i * b + q] * gn[q * b + j];
                    t[i * b + j] = v;
                }
            for (int i = 0; i < b; i++)
                for (int j = 0; j < b; j++) {
                    double v = 0.0;
                    for (int q = 0; q < b; q++) v += t[i * b + q] * wk[j * b + q];
                    m[i * b + j] += v;
                }
        }
        /* g_k = li^T m li */
        for (int i = 0; i < b; i++)
            for (int j = 0; j < b; j++) {
                double v = 0.0;
                for (int q = 0; q < b; q++) v += m[i * b + q] * li[q * b + j];
                t[i * b + j] = v;
            }
        double *gk = g + k * bb;
        for (int i = 0; i < b; i++)
            for (int j = 0; j < b; j++) {
                double v = 0.0;
                for (int q = 0; q < b; q++) v += li[q * b + i] * t[q * b + j];
                gk[i * b + j] = v;
            }
        for (int i = 0; i < b; i++) /* exactly symmetric */
            for (int j = 0; j < i; j++) gk[i * b + j] = gk[j * b + i] = 0.5 * (gk[i * b + j] + gk[j * b + i]);
    }
}

static const char doc_bt_factor[] = "bt_factor(n, b, d, e, l, w) -> -1, or the first block that is not positive "
                                    "definite: block Cholesky of a block-tridiagonal matrix (blocktri).";
static const char doc_bt_solve[] = "bt_solve(n, b, c, l, w, x): x (n, b, c) <- A^-1 x in place (blocktri).";
static const char doc_bt_diag_inverse[] = "bt_diag_inverse(n, b, l, w, g): the diagonal blocks of A^-1 (blocktri).";

static int bt_dims(Py_ssize_t n, int b, int c) {
    if (n < 1 || b < 1 || b > BT_MAX || c < 1) {
        PyErr_Format(PyExc_ValueError, "block-tridiagonal: bad dimensions (n %zd, b %d, c %d; b at most %d)", n, b,
                     c, BT_MAX);
        return -1;
    }
    return 0;
}

static PyObject *py_bt_factor(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    int b;
    PyObject *o[4];
    if (!PyArg_ParseTuple(args, "niOOOO", &n, &b, &o[0], &o[1], &o[2], &o[3]) || bt_dims(n, b, 1) < 0) return NULL;
    const Py_ssize_t bb = (Py_ssize_t)b * b, n1 = n > 1 ? n - 1 : 0;
    Buf bufs[4];
    memset(bufs, 0, sizeof(bufs));
    Py_ssize_t cnt[4] = {n * bb, n1 * bb, n * bb, n1 * bb};
    static const char *names[4] = {"bt_factor d", "bt_factor e", "bt_factor l", "bt_factor w"};
    int k;
    for (k = 0; k < 4; k++)
        if (get_buf(o[k], &bufs[k], 8, cnt[k], k >= 2, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 4) {
        Py_ssize_t bad;
        Py_BEGIN_ALLOW_THREADS
        bad = bt_factor(n, b, bufs[0].view.buf, bufs[1].view.buf, bufs[2].view.buf, bufs[3].view.buf);
        Py_END_ALLOW_THREADS
        res = PyLong_FromSsize_t(bad);
    }
    release(bufs, 4);
    return res;
}

static PyObject *py_bt_solve(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    int b, c;
    PyObject *o[3];
    if (!PyArg_ParseTuple(args, "niiOOO", &n, &b, &c, &o[0], &o[1], &o[2]) || bt_dims(n, b, c) < 0) return NULL;
    const Py_ssize_t bb = (Py_ssize_t)b * b, n1 = n > 1 ? n - 1 : 0;
    Buf bufs[3];
    memset(bufs, 0, sizeof(bufs));
    Py_ssize_t cnt[3] = {n * bb, n1 * bb, n * b * c};
    static const char *names[3] = {"bt_solve l", "bt_solve w", "bt_solve x"};
    int k;
    for (k = 0; k < 3; k++)
        if (get_buf(o[k], &bufs[k], 8, cnt[k], k == 2, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 3) {
        Py_BEGIN_ALLOW_THREADS
        bt_solve(n, b, c, bufs[0].view.buf, bufs[1].view.buf, bufs[2].view.buf);
        Py_END_ALLOW_THREADS
        res = Py_None;
        Py_INCREF(res);
    }
    release(bufs, 3);
    return res;
}

static PyObject *py_bt_diag_inverse(PyObject *self, PyObject *args) {
    Py_ssize_t n;
    int b;
    PyObject *o[3];
    if (!PyArg_ParseTuple(args, "niOOO", &n, &b, &o[0], &o[1], &o[2]) || bt_dims(n, b, 1) < 0) return NULL;
    const Py_ssize_t bb = (Py_ssize_t)b * b, n1 = n > 1 ? n - 1 : 0;
    Buf bufs[3];
    memset(bufs, 0, sizeof(bufs));
    Py_ssize_t cnt[3] = {n * bb, n1 * bb, n * bb};
    static const char *names[3] = {"bt_diag_inverse l", "bt_diag_inverse w", "bt_diag_inverse g"};
    int k;
    for (k = 0; k < 3; k++)
        if (get_buf(o[k], &bufs[k], 8, cnt[k], k == 2, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 3) {
        Py_BEGIN_ALLOW_THREADS
        bt_diag_inverse(n, b, bufs[0].view.buf, bufs[1].view.buf, bufs[2].view.buf);
        Py_END_ALLOW_THREADS
        res = Py_None;
        Py_INCREF(res);
    }
    release(bufs, 3);
    return res;
}

static PyMethodDef methods[] = {
    {"bt_factor", py_bt_factor, METH_VARARGS, doc_bt_factor},
    {"bt_solve", py_bt_solve, METH_VARARGS, doc_bt_solve},
    {"bt_diag_inverse", py_bt_diag_inverse, METH_VARARGS, doc_bt_diag_inverse},
    {"inverse_bands", py_inverse_bands, METH_VARARGS, doc_inverse_bands},
    {"minv_diag", py_minv_diag, METH_VARARGS, doc_minv_diag},
    {"reinsch", py_reinsch, METH_VARARGS, doc_reinsch},
    {"evaluate", py_evaluate, METH_VARARGS, doc_evaluate},
    {"arc_length", py_arc_length, METH_VARARGS, doc_arc_length},
    {"running_median", py_running_median, METH_VARARGS, doc_running_median},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_banded_c",
    "Compiled banded kernels: the smoothing spline's (banded LDL^T solve, selected inverse, evaluation, arc length) "
    "and block-tridiagonal SPD systems (block Cholesky, solve, diagonal of the inverse).", -1,
    methods,
};

PyMODINIT_FUNC PyInit__banded_c(void) { return PyModule_Create(&module); }
