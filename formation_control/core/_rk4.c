/*
 * Copyright 2026 formation_control developers
 *
 * Licensed under the Apache License, Version 2.0 (the "License");
 * you may not use this file except in compliance with the License.
 * You may obtain a copy of the License at
 *
 *     http://www.apache.org/licenses/LICENSE-2.0
 *
 * Unless required by applicable law or agreed to in writing, software
 * distributed under the License is distributed on an "AS IS" BASIS,
 * WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
 * See the License for the specific language governing permissions and
 * limitations under the License.
 */

/*
 * The RK4 integrator of formation_control.core.models in a uniform steady flow, compiled.
 *
 * Each vehicle is integrated on its own numbers: the same classical RK4 steps as
 * models.rk4_step with the input held (models.deriv: (1.1), (1.3), (6.7), (6.15), (8.22),
 * (A.3)), except that cos and sin of each stage's theta are those of the step's start turned
 * by the stage's increment d (angle sums, Taylor series of sin d and cos d - 1, truncation
 * below 1e-17 for |d| <= TURN_MAX; cos and sin themselves beyond it). When omega' is held
 * (every model but rigid_cop) theta is quadratic in time, RK4 is exact on it, and the last
 * stage's (cos, sin) is the next step's. Vehicles are taken in blocks of BLOCK so that the
 * loops over a block run in vector registers; no operation mixes two vehicles and every
 * one is IEEE-rounded (built with -ffp-contract=off: no fused multiply-add), so a vehicle's
 * result does not depend on the others, on the block it falls in or on the instruction set
 * chosen at load time (target_clones).
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <string.h>

/* The kernel ids of the models it integrates, exported as _rk4.FIRST_ORDER, ...: each vehicle
   model of core/vehicles names its own (VehicleModel.kernel); a model without one is not here */
enum { FIRST_ORDER = 0, SECOND_ORDER = 1, RIGID = 2, RIGID_COUPLE = 3, RIGID_COP = 4, NUM_MODELS };
#define TURN_MAX 0.05
#define BLOCK 256

typedef struct {
    double x[6][BLOCK];      /* state rows x, y, theta, omega, u, v */
    double k[6][BLOCK];      /* a stage's rates */
    double z[6][BLOCK];      /* a stage's omega, u, v */
    double acc[6][BLOCK];    /* k1/2 + k2 + k3 + k4/2, then the step */
    double c[BLOCK], s[BLOCK], sc[BLOCK], ss[BLOCK], d[BLOCK];
    double T[BLOCK], F[BLOCK], h[BLOCK], l1[BLOCK];
    double inv_m0[BLOCK], inv_I0[BLOCK], l_I0[BLOCK];   /* 1/m0, 1/I0, -l/I0 */
    unsigned char far[BLOCK];
} Block;

typedef struct { double fx, fy, dt; long steps; } Run;

#define INLINE static inline __attribute__((always_inline))

/* k = dX/dt of vehicle i at omega, u, v = w, u, v and (cos, sin)(theta) = c, s */
INLINE void rates(Block *b, int i, int model, const Run *r, double w, double u, double v,
                  double c, double s)
{
    if (model == FIRST_ORDER || model == SECOND_ORDER) {
        b->k[0][i] = c + r->fx;                                  /* (1.1), (1.3), (1.4) */
        b->k[1][i] = s + r->fy;
        b->k[2][i] = model == FIRST_ORDER ? b->F[i] : w;
        b->k[3][i] = b->F[i];
        return;
    }
    double hs = sqrt(u * u + v * v) * b->h[i];                   /* drag h s^2 along -(u, v) */
    double side = model == RIGID_COUPLE ? -(hs * v) : b->F[i] - hs * v;
    double dw = b->F[i] * b->l_I0[i];                            /* -l F / I0 */
    if (model == RIGID_COP)
        dw -= hs * b->l1[i] * v * b->inv_I0[i];                  /* (A.3) */
    b->k[0][i] = (u * c - v * s) + r->fx;                        /* (6.7), (8.1) */
    b->k[1][i] = (u * s + v * c) + r->fy;
    b->k[2][i] = w;
    b->k[3][i] = dw;
    b->k[4][i] = (b->T[i] - hs * u) * b->inv_m0[i] + v * w;      /* (6.15), (8.22) */
    b->k[5][i] = side * b->inv_m0[i] - u * w;
}

/* sc, ss = (cos, sin)(theta + d) for each vehicle of the block */
INLINE void turn(Block *b, int n)
{
    int far = 0;
    for (int i = 0; i < n; i++) {
        double d = b->d[i], d2 = d * d, c = b->c[i], s = b->s[i];
        double sin_d = d + d * (d2 * (-1.0 / 6 + d2 * (1.0 / 120 + d2 * (-1.0 / 5040))));
        double cos_d1 = d2 * (-0.5 + d2 * (1.0 / 24 + d2 * (-1.0 / 720 + d2 * (1.0 / 40320))));
        b->sc[i] = c + (c * cos_d1 - s * sin_d);
        b->ss[i] = s + (s * cos_d1 + c * sin_d);
        b->far[i] = !(fabs(d) <= TURN_MAX);                      /* NaN too */
        far |= b->far[i];
    }
    if (!far)
        return;
    for (int i = 0; i < n; i++)
        if (b->far[i]) {
            b->sc[i] = cos(b->x[2][i] + b->d[i]);
            b->ss[i] = sin(b->x[2][i] + b->d[i]);
        }
}

/* r->steps RK4 steps of the n vehicles of a block, in place */
INLINE void steps(Block *b, int n, int model, const Run *r)
{
    int moved = model == FIRST_ORDER ? 3 : model == SECOND_ORDER ? 4 : 6;
    double dt = r->dt;
    for (int i = 0; i < n; i++) {
        b->c[i] = cos(b->x[2][i]);
        b->s[i] = sin(b->x[2][i]);
    }
    for (long step = 0; step < r->steps; step++) {
        for (int i = 0; i < n; i++)
            rates(b, i, model, r, b->x[3][i], b->x[4][i], b->x[5][i], b->c[i], b->s[i]);
        for (int row = 0; row < moved; row++)
            for (int i = 0; i < n; i++)
                b->acc[row][i] = 0.5 * b->k[row][i];
        for (int stage = 2; stage <= 4; stage++) {
            double h = stage == 4 ? dt : 0.5 * dt, weight = stage == 4 ? 0.5 : 1.0;
            for (int i = 0; i < n; i++)
                b->d[i] = h * b->k[2][i];
            turn(b, n);
            for (int row = 3; row < moved; row++)
                for (int i = 0; i < n; i++)
                    b->z[row][i] = b->x[row][i] + h * b->k[row][i];
            for (int i = 0; i < n; i++)
                rates(b, i, model, r, b->z[3][i], b->z[4][i], b->z[5][i], b->sc[i], b->ss[i]);
            for (int row = 0; row < moved; row++)
                for (int i = 0; i < n; i++)
                    b->acc[row][i] += weight * b->k[row][i];
        }
        for (int row = 0; row < moved; row++)
            for (int i = 0; i < n; i++)
                b->acc[row][i] *= dt / 3.0;          /* (dt/6)(k1 + 2 k2 + 2 k3 + k4) */
        if (model == RIGID_COP) {                    /* omega' not held: turn by the step */
            memcpy(b->d, b->acc[2], n * sizeof(double));
            turn(b, n);
        }
        memcpy(b->c, b->sc, n * sizeof(double));
        memcpy(b->s, b->ss, n * sizeof(double));
        for (int row = 0; row < moved; row++)
            for (int i = 0; i < n; i++)
                b->x[row][i] += b->acc[row][i];
    }
}

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#endif
static void integrate_block(Block *b, int n, int model, const Run *r)
{
    switch (model) {                                 /* one specialised loop nest per model */
    case FIRST_ORDER: steps(b, n, FIRST_ORDER, r); break;
    case SECOND_ORDER: steps(b, n, SECOND_ORDER, r); break;
    case RIGID: steps(b, n, RIGID, r); break;
    case RIGID_COUPLE: steps(b, n, RIGID_COUPLE, r); break;
    default: steps(b, n, RIGID_COP, r); break;
    }
}

static void integrate_all(double *X, const double *U, const double *P, Py_ssize_t n,
                          Py_ssize_t per, int model, const Run *r, Block *b, double l)
{
    for (Py_ssize_t start = 0; start < n; start += BLOCK) {
        int m = n - start < BLOCK ? (int)(n - start) : BLOCK;
        for (int row = 0; row < 6; row++)
            memcpy(b->x[row], X + row * n + start, m * sizeof(double));
        memcpy(b->T, U + start, m * sizeof(double));
        memcpy(b->F, U + n + start, m * sizeof(double));
        for (int i = 0; i < m; i++) {
            Py_ssize_t j = per == 1 ? 0 : start + i;
            b->inv_m0[i] = 1.0 / P[j];
            b->inv_I0[i] = 1.0 / P[per + j];
            b->l_I0[i] = -l / P[per + j];
            b->h[i] = P[2 * per + j];
            b->l1[i] = P[3 * per + j];
        }
        integrate_block(b, m, model, r);
        for (int row = 0; row < 6; row++)
            memcpy(X + row * n + start, b->x[row], m * sizeof(double));
    }
}

PyDoc_STRVAR(integrate_doc,
"integrate(X, U, P, model, dt, steps, l, fx, fy)\n--\n\n"
"Take ``steps`` RK4 steps of ``dt`` of every vehicle in place, the inputs held.\n\n"
"X: C-contiguous float64 (6, n), rows x, y, theta, omega, u, v (written); U: (2, n) inputs;\n"
"P: (4, 1) or (4, n) m0, I0, h, l1; model: a kernel id (_rk4.FIRST_ORDER, SECOND_ORDER, RIGID,\n"
"RIGID_COUPLE, RIGID_COP: VehicleModel.kernel); l: the steering arm;\n"
"fx, fy: the uniform steady flow (m/s).");

static PyObject *integrate(PyObject *self, PyObject *args)
{
    Py_buffer xb, ub, pb;
    int model;
    double l;
    Run r;
    if (!PyArg_ParseTuple(args, "w*y*y*idlddd", &xb, &ub, &pb, &model, &r.dt, &r.steps, &l,
                          &r.fx, &r.fy))
        return NULL;
    Py_ssize_t n = xb.len / (6 * (Py_ssize_t)sizeof(double));
    Py_ssize_t per = pb.len / (4 * (Py_ssize_t)sizeof(double));
    const char *error = NULL;
    if (xb.len != 6 * n * (Py_ssize_t)sizeof(double))
        error = "X must hold 6 rows of float64";
    else if (ub.len != 2 * n * (Py_ssize_t)sizeof(double))
        error = "U must hold 2 float64 rows of X's length";
    else if (pb.len != 4 * per * (Py_ssize_t)sizeof(double) || (per != 1 && per != n))
        error = "P must hold 4 float64 rows of length 1 or X's";
    else if (model < 0 || model >= NUM_MODELS)
        error = "model must index the kernel's models (_rk4.FIRST_ORDER .. _rk4.RIGID_COP)";
    else if (r.steps < 0)
        error = "steps must be >= 0";
    Block *b = error ? NULL : PyMem_RawCalloc(1, sizeof(Block));
    if (b) {
        Py_BEGIN_ALLOW_THREADS
        integrate_all(xb.buf, ub.buf, pb.buf, n, per, model, &r, b, l);
        Py_END_ALLOW_THREADS
        PyMem_RawFree(b);
    }
    PyBuffer_Release(&xb);
    PyBuffer_Release(&ub);
    PyBuffer_Release(&pb);
    if (error) {
        PyErr_SetString(PyExc_ValueError, error);
        return NULL;
    }
    if (!b)
        return PyErr_NoMemory();
    Py_RETURN_NONE;
}

static PyMethodDef methods[] = {
    {"integrate", integrate, METH_VARARGS, integrate_doc},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_rk4", "The compiled RK4 of formation_control.core.models.", -1,
    methods,
};

PyMODINIT_FUNC PyInit__rk4(void)
{
    PyObject *m = PyModule_Create(&module);
    if (m == NULL)
        return NULL;
    if (PyModule_AddIntConstant(m, "FIRST_ORDER", FIRST_ORDER) < 0
            || PyModule_AddIntConstant(m, "SECOND_ORDER", SECOND_ORDER) < 0
            || PyModule_AddIntConstant(m, "RIGID", RIGID) < 0
            || PyModule_AddIntConstant(m, "RIGID_COUPLE", RIGID_COUPLE) < 0
            || PyModule_AddIntConstant(m, "RIGID_COP", RIGID_COP) < 0) {
        Py_DECREF(m);
        return NULL;
    }
    return m;
}
