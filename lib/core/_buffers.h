/* Buffer-protocol helpers shared by the optional C extensions that take 8-byte items (float64 or int64):
 * skijump/_ski_c.c and climbing/_climbing_c.c include this file.  No numpy headers are needed to build. */
#ifndef SPORTFUSION_BUFFERS_H
#define SPORTFUSION_BUFFERS_H

#define PY_SSIZE_T_CLEAN
#include <Python.h>

typedef struct {
    Py_buffer view;
    int held;
} Buf;

/* A C-contiguous buffer of `count` 8-byte items (count < 0: any number, at least -count); name for the error. */
static int get_buf(PyObject *obj, Buf *b, Py_ssize_t count, int writable, const char *name) {
    int flags = PyBUF_C_CONTIGUOUS | (writable ? PyBUF_WRITABLE : 0);
    b->held = 0;
    if (PyObject_GetBuffer(obj, &b->view, flags) < 0) return -1;
    b->held = 1;
    if (b->view.itemsize != 8 || (count >= 0 && b->view.len != 8 * count) || (count < 0 && b->view.len < 8 * -count)) {
        PyErr_Format(PyExc_ValueError, "%s: expected %zd 8-byte items, got %zd bytes", name, count, b->view.len);
        return -1;
    }
    return 0;
}

/* release the first `count` buffers that were taken */
static void release(Buf *b, int count) {
    for (int i = 0; i < count; i++)
        if (b[i].held) PyBuffer_Release(&b[i].view);
}

#endif
