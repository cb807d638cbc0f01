/* pf-holds' loops as a C extension: the climbing particle filter's forward pass, its backward-simulation
 * paths and the complementary filter of the transition estimator's initial orientations.
 *
 * sportfusion.climbing.particles.run_particle_filter computes the same in numpy, over blocks of steps
 * (that path stays the reference the tests compare this one with, and the fallback when this optional
 * extension is not built); sportfusion.climbing.orientation.complementary_filter likewise.  Here the
 * particle filter runs step by step: eq 17's prediction with the process noise
 * drawn by the caller, the grip likelihood of eqs 18-22 (nearest hold centre), the weights per start-hold
 * stratum with their evidence, the merge of the strata, systematic resampling and the most likely
 * cluster's outputs.  The random numbers all come from the caller, so both paths draw the same ones.
 *
 * Arrays travel through the buffer protocol (no numpy headers needed to build): C-contiguous, 8-byte
 * items (float64, or int64 where named *_i below); the Python side checks shapes and allocates outputs.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "../core/_buffers.h"
#include "../core/_quat.h"

/* indices of systematic resampling (sportfusion.estimators.particles.systematic_resample) of the weights
 * exp(lw[idx[i]] - top), i < size, normalised; count draws written to out (indices into idx) */
static void systematic(const double *lw, const int64_t *idx, int64_t size, double u0, int64_t count, int64_t *out,
                       double *cum) {
    double top = -INFINITY, s = 0.0;
    for (int64_t i = 0; i < size; i++)
        if (lw[idx[i]] > top) top = lw[idx[i]];
    for (int64_t i = 0; i < size; i++) {
        cum[i] = exp(lw[idx[i]] - top);
        s += cum[i];
    }
    double c = 0.0;
    for (int64_t i = 0; i < size; i++) {
        c += cum[i] / s;
        cum[i] = c;
    }
    cum[size - 1] = 1.0;
    int64_t j = 0;
    for (int64_t i = 0; i < count; i++) {
        double u = (u0 + (double)i) / (double)count;
        while (j < size - 1 && cum[j] < u) j++; /* searchsorted(cum, u, "left"), capped at size - 1 */
        out[i] = j;
    }
}

/* per stratum st[i] < ns of the log weights: the log of the weights' sum (each stratum relative to its own
 * largest, so that none underflows) and the effective sample size within the stratum; hw (m) gets the weights
 * normalised within their stratum */
static void strata_sums(const double *lw, const int64_t *st, int64_t m, int64_t ns, double *tops, double *lsum,
                        double *ess, double *hw) {
    for (int64_t h = 0; h < ns; h++) tops[h] = -INFINITY, lsum[h] = 0.0, ess[h] = 0.0;
    for (int64_t i = 0; i < m; i++)
        if (lw[i] > tops[st[i]]) tops[st[i]] = lw[i];
    for (int64_t i = 0; i < m; i++) {
        double e = exp(lw[i] - tops[st[i]]);
        hw[i] = e;
        lsum[st[i]] += e;
        ess[st[i]] += e * e;
    }
    for (int64_t h = 0; h < ns; h++) ess[h] = lsum[h] * lsum[h] / ess[h];
    for (int64_t i = 0; i < m; i++) hw[i] /= lsum[st[i]];
    for (int64_t h = 0; h < ns; h++) lsum[h] = tops[h] + log(lsum[h]);
}

/* log(sum_h exp(a_h)) */
static double log_sum(const double *a, int64_t ns) {
    double top = -INFINITY, s = 0.0;
    for (int64_t h = 0; h < ns; h++)
        if (a[h] > top) top = a[h];
    for (int64_t h = 0; h < ns; h++) s += exp(a[h] - top);
    return top + log(s);
}

typedef struct {
    int64_t n, m, k0, ncodes, nowhere, nstrata, nr, nw;
    double radius, sigma, log_peak, log_other, ess_fraction;
} Dims;

/* The forward pass: particles.run_particle_filter's numpy loop over blocks of steps, here step by step (the same
 * prediction, likelihood, strata, merge and resampling, the same random numbers).  Returns the merge step (-1:
 * never; k0 with one stratum; -2: the refill callback raised), sets *resamples.  Runs steps kb .. ke - 1 and
 * leaves in state (with work, iwork and start_ev) what a call for the next block resumes from
 * (climbing/_pfblocks.py: the smoother runs the blocks again, so that no history of the whole run is held). */
static int64_t forward(const Dims *d, const double *horiz, const double *kstep, const double *normal_pos,
                       const double *chol, const double *ustep, const double *add_psi, const double *u_res, const int64_t *grip, const int64_t *grip_end,
                       const int64_t *late, const double *temper, const double *r_pos, const int64_t *r_code,
                       const double *w_pos, const int64_t *w_code, const double *pos0, const double *psi0,
                       const int64_t *lab0, const int64_t *which, double *hist, double *hist_w, int64_t *hist_lab,
                       int64_t *anc, double *out_pos, int64_t *out_code, double *out_prob, double *out_yaw,
                       double *out_ev, double *start_ev, int64_t *resamples, double *work, int64_t *iwork,
                       PyObject *refill, int64_t blk, int64_t kb, int64_t ke, double *state) {
    const int64_t n = d->n, m = d->m, k0 = d->k0, nc = d->ncodes;
    int64_t ns = d->nstrata;
    /* work: pos (3m), psi (m), lw (m), ws (m), cum (m), new pos (3m), new psi (m), sums (nc * (ns + 1)), and per
     * stratum lsum, lsum0, ess, hyp_p, tops (5 ns) */
    double *pos = work, *psi = pos + 3 * m, *lw = psi + m, *ws = lw + m, *cum = ws + m, *npos = cum + m;
    double *npsi = npos + 3 * m, *sums = npsi + m, *lsum = sums + nc * (ns + 1), *lsum0 = lsum + ns;
    double *ess = lsum0 + ns, *hyp_p = ess + ns, *tops = hyp_p + ns;
    /* iwork: lab (m), new lab (m), idx (m), members (m), draws (m), stratum of each particle (m), counts (ns) */
    int64_t *lab = iwork, *nlab = lab + m, *idx = nlab + m, *mem = idx + m, *draw = mem + m, *st = draw + m;
    int64_t *counts = st + m;
    int64_t merged_at = ns > 1 ? -1 : k0, best = 0;
    int fresh = 1; /* the particles were resampled at the last step: normalise their weights again */
    double log_z = 0.0;
    if (kb > k0) { /* a later block: the filter's state where the last one stopped (work, iwork, start_ev, state) */
        ns = (int64_t)state[0], merged_at = (int64_t)state[1], best = (int64_t)state[2];
        fresh = (int)state[3], log_z = state[4], *resamples = (int64_t)state[5];
    }
    for (int64_t k = kb; k < ke; k++) {
        if (kb == k0 && k == k0) {
            memcpy(pos, pos0, 3 * m * sizeof(double));
            memcpy(psi, psi0, m * sizeof(double));
            memcpy(lab, lab0, m * sizeof(int64_t));
            for (int64_t h = 0; h < ns; h++) counts[h] = 0;
            for (int64_t i = 0; i < m; i++) {
                st[i] = ns > 1 ? which[i] : 0;
                counts[st[i]]++;
                lw[i] = 0.0;
            }
            for (int64_t h = 0; h < ns; h++) start_ev[h] = 0.0, lsum[h] = log((double)counts[h]);
            *resamples = 0;
        }
        if (k > k0) { /* eq 17 from k - 1: pos + Rot_up(psi) step + noise, the yaw of step k - 1 */
            const int64_t j = k - 1 - k0, jj = refill ? j % blk : j; /* jj: the row of the noise buffers */
            if (refill && jj == 0) { /* the caller draws the noise of steps j .. j + blk - 1 into the buffers */
                PyObject *r = PyObject_CallFunction(refill, "L", (long long)j);
                if (!r) return -2;
                Py_DECREF(r);
            }
            const double *z = normal_pos + 3 * m * jj, *L = chol + 9 * j, *us = ustep + 3 * (k - 1);
            const double *hz = horiz + 3 * (k - 1), *ks = kstep + 3 * (k - 1);
            for (int64_t i = 0; i < m; i++) {
                double c = cos(psi[i]), s = sin(psi[i]);
                const double *zi = z + 3 * i;
                for (int a = 0; a < 3; a++) {
                    double e = L[3 * a] * zi[0] + L[3 * a + 1] * zi[1] + L[3 * a + 2] * zi[2] + us[a];
                    pos[3 * i + a] += e + hz[a] * c + ks[a] * s;
                }
                psi[i] += add_psi[m * jj + i];
            }
        }
        double *hk = hist + 4 * m * (k - kb); /* the history buffers hold the block's steps kb .. ke - 1 */
        for (int64_t i = 0; i < m; i++) {
            hk[4 * i] = pos[3 * i];
            hk[4 * i + 1] = pos[3 * i + 1];
            hk[4 * i + 2] = pos[3 * i + 2];
            hk[4 * i + 3] = psi[i];
        }
        int g = grip[k] != 0;
        double *hw = hist_w + m * (k - kb + 1); /* hist_w's row 0: the weights of step kb - 1 */
        if (g) { /* eq 18: the best hold or "elsewhere", per particle */
            const double *cen = late[k] ? w_pos : r_pos;
            const int64_t *code = late[k] ? w_code : r_code;
            const int64_t nh = late[k] ? d->nw : d->nr;
            const double tw = temper ? temper[k] : 1.0;
            /* lsum: each stratum's log total weight, kept up to date (resampling keeps the totals) */
            memcpy(lsum0, lsum, ns * sizeof(double));
            double all0 = log_sum(lsum0, ns);
            for (int64_t i = 0; i < m; i++) {
                const double *p = pos + 3 * i;
                double best = INFINITY;
                int64_t bi = 0;
                for (int64_t c = 0; c < nh; c++) {
                    double dx = p[0] - cen[3 * c], dy = p[1] - cen[3 * c + 1], dz = p[2] - cen[3 * c + 2];
                    double d2 = dx * dx + dy * dy + dz * dz;
                    if (d2 < best) {
                        best = d2;
                        bi = c;
                    }
                }
                double ex = sqrt(best) - d->radius;
                ex = ex > 0.0 ? ex / d->sigma : 0.0;
                double logh = d->log_peak - 0.5 * ex * ex;
                int at_hold = logh > d->log_other;
                lw[i] += tw * (at_hold ? logh : d->log_other);
                lab[i] = at_hold ? code[bi] : d->nowhere;
            }
            /* the evidence: per stratum (while there are several) and of all particles, log(sum w l / sum w) */
            strata_sums(lw, st, m, ns, tops, lsum, ess, hw);
            double all1 = log_sum(lsum, ns), top1 = -INFINITY;
            if (ns > 1)
                for (int64_t h = 0; h < ns; h++) start_ev[h] += lsum[h] - lsum0[h];
            log_z += all1 - all0;
            for (int64_t i = 0; i < m; i++)
                if (lw[i] > top1) top1 = lw[i];
            for (int64_t i = 0; i < m; i++) lw[i] -= top1; /* relative to the largest, as in numpy */
            for (int64_t h = 0; h < ns; h++) lsum[h] -= top1;
        }
        out_ev[k] = log_z;
        if (fresh || g) { /* weights normalised within the strata (hist_w) and between them by their evidence (ws) */
            if (!g)
                for (int64_t i = 0; i < m; i++) hw[i] = exp(lw[i] - lsum[st[i]]);
            double hmax = -INFINITY, hs = 0.0;
            for (int64_t h = 0; h < ns; h++)
                if (start_ev[h] > hmax) hmax = start_ev[h];
            for (int64_t h = 0; h < ns; h++) hs += hyp_p[h] = exp(start_ev[h] - hmax);
            for (int64_t i = 0; i < m; i++) ws[i] = ns > 1 ? hw[i] * hyp_p[st[i]] / hs : hw[i];
            /* the most likely cluster (ties: the lowest code) */
            memset(sums, 0, nc * sizeof(double));
            for (int64_t i = 0; i < m; i++) sums[lab[i]] += ws[i];
            best = 0;
            for (int64_t c = 1; c < nc; c++)
                if (sums[c] > sums[best]) best = c;
        } else { /* no grip and no resampling since the last step: the same weights and clusters */
            memcpy(hw, hw - m, m * sizeof(double));
        }
        fresh = 0;
        memcpy(hist_lab + m * (k - kb), lab, m * sizeof(int64_t));
        double prob = sums[best], mx = 0.0, my = 0.0, mz = 0.0, myaw = 0.0;
        for (int64_t i = 0; i < m; i++)
            if (lab[i] == best) {
                double w = ws[i] / prob;
                mx += w * pos[3 * i];
                my += w * pos[3 * i + 1];
                mz += w * pos[3 * i + 2];
                myaw += w * psi[i];
            }
        out_pos[3 * k] = mx, out_pos[3 * k + 1] = my, out_pos[3 * k + 2] = mz;
        out_code[k] = best, out_prob[k] = prob, out_yaw[k] = myaw;
        if (!g) continue;
        /* merge: at the end of a grip, every stratum's most likely cluster is the same hold */
        int merge = 0, low = 0;
        if (ns > 1 && grip_end[k]) {
            double *sh = sums + nc;
            memset(sh, 0, nc * ns * sizeof(double));
            for (int64_t i = 0; i < m; i++) sh[st[i] * nc + lab[i]] += hw[i];
            int64_t b0 = -1;
            merge = 1;
            for (int64_t h = 0; h < ns && merge; h++) {
                int64_t bh = 0;
                for (int64_t c = 1; c < nc; c++)
                    if (sh[h * nc + c] > sh[h * nc + bh]) bh = c;
                if (h == 0) b0 = bh;
                merge = bh == b0 && bh != d->nowhere;
            }
        }
        for (int64_t h = 0; h < ns; h++) low |= ess[h] < d->ess_fraction * (double)counts[h];
        if (!merge && !low) continue;
        for (int64_t i = 0; i < m; i++) idx[i] = i;
        if (merge) { /* the stratum with the larger evidence takes all particles */
            int64_t bh = 0, sz = 0;
            for (int64_t h = 1; h < ns; h++)
                if (start_ev[h] > start_ev[bh]) bh = h;
            for (int64_t i = 0; i < m; i++)
                if (st[i] == bh) mem[sz++] = i;
            systematic(lw, mem, sz, u_res[k], m, draw, cum);
            for (int64_t i = 0; i < m; i++) idx[i] = mem[draw[i]];
            for (int64_t i = 0; i < m; i++) lw[i] = 0.0, st[i] = 0;
            ns = 1;
            counts[0] = m;
            lsum[0] = log((double)m);
            merged_at = k;
        } else {
            for (int64_t h = 0; h < ns; h++) {
                if (!(ess[h] < d->ess_fraction * (double)counts[h])) continue;
                int64_t sz = 0;
                for (int64_t i = 0; i < m; i++)
                    if (st[i] == h) mem[sz++] = i;
                systematic(lw, mem, sz, u_res[k], sz, draw, cum);
                double keep = lsum[h] - log((double)counts[h]); /* the stratum keeps its total weight */
                for (int64_t i = 0; i < sz; i++) idx[mem[i]] = mem[draw[i]];
                for (int64_t i = 0; i < sz; i++) lw[mem[i]] = keep;
            }
        }
        if (k < n - 1) memcpy(anc + m * (k - kb), idx, m * sizeof(int64_t));
        for (int64_t i = 0; i < m; i++) {
            int64_t s = idx[i];
            npos[3 * i] = pos[3 * s], npos[3 * i + 1] = pos[3 * s + 1], npos[3 * i + 2] = pos[3 * s + 2];
            npsi[i] = psi[s];
            nlab[i] = lab[s];
        }
        memcpy(pos, npos, 3 * m * sizeof(double));
        memcpy(psi, npsi, m * sizeof(double));
        memcpy(lab, nlab, m * sizeof(int64_t));
        (*resamples)++;
        fresh = 1;
    }
    state[0] = (double)ns, state[1] = (double)merged_at, state[2] = (double)best;
    state[3] = (double)fresh, state[4] = log_z, state[5] = (double)*resamples;
    return merged_at;
}

static PyObject *py_forward(PyObject *self, PyObject *args) {
    Dims d;
    PyObject *o[32], *refill = Py_None;
    long long blk = 0, kb = 0, ke = 0;
    if (!PyArg_ParseTuple(args, "LLLLLLLLdddddOOOOOOOOOOOOOOOOOOOOOOOOOOOOOOOOLLLO", &d.n, &d.m, &d.k0, &d.ncodes,
                          &d.nowhere, &d.nstrata, &d.nr, &d.nw, &d.radius, &d.sigma, &d.log_peak, &d.log_other,
                          &d.ess_fraction, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8], &o[9],
                          &o[10], &o[11], &o[12], &o[13], &o[14], &o[15], &o[16], &o[17], &o[18], &o[19], &o[20],
                          &o[21], &o[22], &o[23], &o[24], &o[25], &o[26], &o[27], &o[28], &o[29], &o[30], &refill,
                          &blk, &kb, &ke, &o[31]))
        return NULL;
    const int64_t n = d.n, m = d.m, nk = n - 1 - d.k0 > 0 ? n - 1 - d.k0 : 0;
    /* refill (None: the noise arrays hold every step): a callable drawing the noise of blk steps from step j into
     * normal_pos (blk, m, 3) and add_psi (blk, m), called when the loop reaches j = 0, blk, 2 blk, ... (the GIL is
     * kept for it).  The loop runs steps kb .. ke - 1: the history buffers (hist, hist_lab, anc) hold those steps,
     * hist_w one row more in front (the weights of step kb - 1); a block after the first (kb > k0) resumes from
     * work, iwork, start_ev and state (6 numbers) as the block before left them, and with a refill starts at a
     * noise block (kb - 1 - k0 a multiple of blk). */
    if (refill == Py_None) refill = NULL;
    if (refill && (!PyCallable_Check(refill) || blk < 1)) {
        PyErr_SetString(PyExc_ValueError, "pf_forward: refill must be callable with a block of at least 1 step");
        return NULL;
    }
    const int64_t span = ke - kb;
    const int64_t rows = refill ? (blk < nk ? blk : nk) : nk; /* steps the noise buffers hold */
    if (n < 1 || m < 2 || d.k0 < 0 || d.k0 >= n || d.nstrata < 1 || d.nr < 1 || d.nw < 1 || d.ncodes < 1) {
        PyErr_SetString(PyExc_ValueError, "pf_forward: bad dimensions");
        return NULL;
    }
    if (kb < d.k0 || ke <= kb || ke > n || (kb > d.k0 && refill && (kb - 1 - d.k0) % blk != 0) ||
        (kb > d.k0 && !refill)) {
        PyErr_SetString(PyExc_ValueError, "pf_forward: bad block of steps");
        return NULL;
    }
    int has_temper = o[10] != Py_None;
    const Py_ssize_t n1 = n - 1 > 0 ? n - 1 : 1;
    static const char *names[32] = {
        "horiz", "kstep",   "normal_pos", "chol",    "ustep",   "add_psi", "u_res",    "grip",     "grip_end",
        "late",  "temper",  "r_pos",      "r_code",  "w_pos",   "w_code",  "pos0",     "psi0",     "lab0",
        "which", "hist",    "hist_w",     "hist_lab", "anc",    "out_pos", "out_code", "out_prob", "out_yaw",
        "out_ev", "start_ev", "work",     "iwork",    "state"};
    Py_ssize_t cnt[32] = {3 * n1, 3 * n1, 3 * m * rows, 9 * nk, 3 * n1, m * rows, n, n, n, n, n, 3 * d.nr, d.nr,
                          3 * d.nw, d.nw, 3 * m, m, m, m, 4 * m * span, m * (span + 1), m * span, m * span, 3 * n, n,
                          n, n, n, d.nstrata, 11 * m + d.ncodes * (d.nstrata + 1) + 5 * d.nstrata, 6 * m + d.nstrata,
                          6};
    Buf b[32];
    memset(b, 0, sizeof(b));
    int k;
    for (k = 0; k < 32; k++) {
        if (k == 10 && !has_temper) continue;
        if ((k == 2 || k == 3 || k == 5) && nk == 0) continue;
        if (get_buf(o[k], &b[k], cnt[k], k >= 19, names[k]) < 0) break;
    }
    PyObject *res = NULL;
    if (k == 32) { /* the codes index the cluster sums and the strata: checked here, the loop trusts them */
        const int64_t *rc = b[12].view.buf, *wc = b[14].view.buf, *l0 = b[17].view.buf, *wh = b[18].view.buf;
        int ok = d.nowhere >= 0 && d.nowhere < d.ncodes;
        for (int64_t i = 0; i < d.nr && ok; i++) ok = rc[i] >= 0 && rc[i] < d.ncodes;
        for (int64_t i = 0; i < d.nw && ok; i++) ok = wc[i] >= 0 && wc[i] < d.ncodes;
        for (int64_t i = 0; i < m && ok; i++)
            ok = l0[i] >= 0 && l0[i] < d.ncodes && (d.nstrata == 1 || (wh[i] >= 0 && wh[i] < d.nstrata));
        int64_t filled[64] = {0};
        for (int64_t i = 0; i < m && ok && d.nstrata > 1 && d.nstrata <= 64; i++) filled[wh[i]]++;
        for (int64_t h = 0; h < d.nstrata && ok && d.nstrata > 1; h++) ok = d.nstrata <= 64 && filled[h] > 0;
        if (!ok) {
            PyErr_SetString(PyExc_ValueError, "pf_forward: a hold code or stratum out of range (or an empty stratum)");
            k = 0;
        }
    }
    if (k == 32) {
        void *p[32];
        for (int i = 0; i < 32; i++) p[i] = b[i].held ? b[i].view.buf : NULL;
        int64_t resamples = 0, merged;
#define PF_FORWARD(cb)                                                                                              \
    forward(&d, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12], p[13], p[14], p[15], \
            p[16], p[17], p[18], p[19], p[20], p[21], p[22], p[23], p[24], p[25], p[26], p[27], p[28], &resamples,    \
            p[29], p[30], cb, blk, kb, ke, p[31])
        if (refill) { /* the callback needs the GIL: the loop keeps it */
            merged = PF_FORWARD(refill);
        } else {
            Py_BEGIN_ALLOW_THREADS
            merged = PF_FORWARD(NULL);
            Py_END_ALLOW_THREADS
        }
#undef PF_FORWARD
        res = merged == -2 ? NULL : Py_BuildValue("LL", (long long)merged, (long long)resamples);
    }
    release(b, 32);
    return res;
}

/* Backward simulation with Metropolis-Hastings moves (sportfusion.estimators.particles.backward_simulation_gaussian)
 * for eq 17's transition density: log f(x_k+1(j) | x_k(i)) = -|L_k^-1 (p_k+1(j) - predict_k(i))|^2 / 2
 * - ((psi_k+1(j) - psi_k(i)) / s_k)^2 / 2 with predict_k(i) = p_k(i) + horiz_k cos psi + kstep_k sin psi + ustep_k
 * (L_k lower triangular).  Fills the trajectories' particles path (n - k0, m). */
/* eq 17's prediction of every particle of step k without noise: predicted position and yaw, (m, 4) */
static void predict_all(int64_t m, const double *xk, const double *hz, const double *ks, const double *us,
                        double *pred) {
    for (int64_t i = 0; i < m; i++) {
        const double *x = xk + 4 * i;
        double c = cos(x[3]), s = sin(x[3]);
        for (int a = 0; a < 3; a++) pred[4 * i + a] = x[a] + hz[a] * c + ks[a] * s + us[a];
        pred[4 * i + 3] = x[3];
    }
}

/* -2 log f up to a constant: the whitened squared distance of x_k+1(j) from a prediction (L lower
 * triangular with its diagonal's inverses id) */
static inline double neg2logf(const double *pred, const double *xj, const double *L, const double *id,
                              double inv_s) {
    double z0 = (xj[0] - pred[0]) * id[0];
    double z1 = (xj[1] - pred[1] - L[3] * z0) * id[1];
    double z2 = (xj[2] - pred[2] - L[6] * z0 - L[7] * z1) * id[2];
    double zy = (xj[3] - pred[3]) * inv_s;
    return z0 * z0 + z1 * z1 + z2 * z2 + zy * zy;
}

static void backward_paths(int64_t n, int64_t m, int64_t k0, int64_t moves, const int64_t *j0, const double *cum,
                           const double *u, const double *thr, const int64_t *anc, const double *hist,
                           const double *horiz, const double *kstep, const double *ustep, const double *chol,
                           const double *yaw_sigma, int64_t *path, double *pred) {
    int64_t *j = path + (n - 1 - k0) * m;
    memcpy(j, j0, m * sizeof(int64_t));
    for (int64_t k = n - 2; k >= k0; k--) {
        const int64_t r = k - k0;
        int64_t *out = path + r * m;
        const int64_t *ak = anc + k * m;
        const double *ck = cum + r * m, *xk1 = hist + 4 * m * (k + 1), *L = chol + 9 * k;
        const double inv_s = 1.0 / yaw_sigma[k], id[3] = {1.0 / L[0], 1.0 / L[4], 1.0 / L[8]};
        if (moves) predict_all(m, hist + 4 * m * k, horiz + 3 * k, kstep + 3 * k, ustep + 3 * k, pred);
        for (int64_t t = 0; t < m; t++) {
            const int64_t jt = j[t];
            int64_t cur = ak[jt];
            const double *xj = xk1 + 4 * jt;
            double sc = moves ? neg2logf(pred + 4 * cur, xj, L, id, inv_s) : 0.0;
            for (int64_t mv = 0; mv < moves; mv++) {
                const double uu = u[(r * moves + mv) * m + t];
                /* searchsorted(cum, u, "right"): the first index with cum > u (branch-free halving) */
                const double *base = ck;
                int64_t len = m;
                while (len > 1) {
                    int64_t half = len >> 1;
                    base = base[half - 1] <= uu ? base + half : base;
                    len -= half;
                }
                int64_t prop = (base - ck) + (*base <= uu);
                if (prop > m - 1) prop = m - 1;
                double sp = neg2logf(pred + 4 * prop, xj, L, id, inv_s);
                if (sp - sc < thr[(r * moves + mv) * m + t]) cur = prop, sc = sp;
            }
            out[t] = cur;
        }
        j = out;
    }
}

static PyObject *py_paths(PyObject *self, PyObject *args) {
    long long n, m, k0, moves;
    PyObject *o[12];
    if (!PyArg_ParseTuple(args, "LLLLOOOOOOOOOOOO", &n, &m, &k0, &moves, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5],
                          &o[6], &o[7], &o[8], &o[9], &o[10], &o[11]))
        return NULL;
    if (n < 2 || m < 1 || k0 < 0 || k0 > n - 2 || moves < 0) {
        PyErr_SetString(PyExc_ValueError, "backward_paths: bad dimensions (needs n >= 2, k0 <= n - 2)");
        return NULL;
    }
    const long long steps = n - 1 - k0;
    static const char *names[12] = {"j",     "cum",   "u",     "thr",  "ancestors", "hist",
                                    "horiz", "kstep", "ustep", "chol", "yaw_sigma", "path"};
    Py_ssize_t cnt[12] = {m, steps * m, steps * moves * m, steps * moves * m, (n - 1) * m, 4 * n * m,
                          3 * (n - 1), 3 * (n - 1), 3 * (n - 1), 9 * (n - 1), n - 1, (n - k0) * m};
    Buf b[12];
    memset(b, 0, sizeof(b));
    int k;
    for (k = 0; k < 12; k++) {
        if (moves == 0 && (k == 2 || k == 3)) continue;
        if (get_buf(o[k], &b[k], cnt[k], k == 11, names[k]) < 0) break;
    }
    PyObject *res = NULL;
    double *pred = k == 12 ? PyMem_RawMalloc(4 * m * sizeof(double)) : NULL;
    if (k == 12 && !pred) PyErr_NoMemory();
    if (pred) {
        Py_BEGIN_ALLOW_THREADS
        backward_paths(n, m, k0, moves, b[0].view.buf, b[1].view.buf, moves ? b[2].view.buf : NULL,
                       moves ? b[3].view.buf : NULL, b[4].view.buf, b[5].view.buf, b[6].view.buf, b[7].view.buf,
                       b[8].view.buf, b[9].view.buf, b[10].view.buf, b[11].view.buf, pred);
        Py_END_ALLOW_THREADS
        PyMem_RawFree(pred);
        res = Py_None;
        Py_INCREF(res);
    }
    release(b, 12);
    return res;
}

/* The smoother's outputs per step from the trajectories' particles path (n - k0, m): each particle's weight
 * is the fraction of the trajectories through it; the most likely cluster (ties: the lowest code), its
 * probability and its weighted mean position and yaw (particles.py's _cluster_rows on path_weights). */
static void path_clusters(int64_t n, int64_t m, int64_t k0, int64_t nc, const int64_t *path, const double *hist,
                          const int64_t *hist_lab, double *out_pos, int64_t *out_code, double *out_prob,
                          double *out_yaw, double *w, double *sums) {
    const double inv_m = 1.0 / (double)m;
    for (int64_t k = k0; k < n; k++) {
        const int64_t *pk = path + (k - k0) * m, *lab = hist_lab + k * m;
        const double *x = hist + 4 * m * k;
        for (int64_t i = 0; i < m; i++) w[i] = 0.0;
        for (int64_t t = 0; t < m; t++) w[pk[t]] += 1.0;
        for (int64_t i = 0; i < m; i++) w[i] *= inv_m;
        memset(sums, 0, nc * sizeof(double));
        for (int64_t i = 0; i < m; i++) sums[lab[i]] += w[i];
        int64_t best = 0;
        for (int64_t c = 1; c < nc; c++)
            if (sums[c] > sums[best]) best = c;
        double prob = sums[best], mx = 0.0, my = 0.0, mz = 0.0, myaw = 0.0;
        for (int64_t i = 0; i < m; i++)
            if (lab[i] == best && w[i] > 0.0) {
                double wi = w[i] / prob;
                mx += wi * x[4 * i], my += wi * x[4 * i + 1], mz += wi * x[4 * i + 2], myaw += wi * x[4 * i + 3];
            }
        out_pos[3 * k] = mx, out_pos[3 * k + 1] = my, out_pos[3 * k + 2] = mz;
        out_code[k] = best, out_prob[k] = prob, out_yaw[k] = myaw;
    }
}

static PyObject *py_path_clusters(PyObject *self, PyObject *args) {
    long long n, m, k0, nc;
    PyObject *o[7];
    if (!PyArg_ParseTuple(args, "LLLLOOOOOOO", &n, &m, &k0, &nc, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6]))
        return NULL;
    if (n < 1 || m < 1 || k0 < 0 || k0 >= n || nc < 1) {
        PyErr_SetString(PyExc_ValueError, "path_clusters: bad dimensions");
        return NULL;
    }
    static const char *names[7] = {"path", "hist", "hist_lab", "out_pos", "out_code", "out_prob", "out_yaw"};
    Py_ssize_t cnt[7] = {(n - k0) * m, 4 * n * m, n * m, 3 * n, n, n, n};
    Buf b[7];
    memset(b, 0, sizeof(b));
    int k;
    for (k = 0; k < 7; k++)
        if (get_buf(o[k], &b[k], cnt[k], k >= 3, names[k]) < 0) break;
    PyObject *res = NULL;
    double *work = k == 7 ? PyMem_RawMalloc((m + nc) * sizeof(double)) : NULL;
    if (k == 7 && !work) PyErr_NoMemory();
    if (work) {
        /* codes must index the sums: checked here, the loop trusts them */
        const int64_t *lab = b[2].view.buf;
        int ok = 1;
        for (Py_ssize_t i = k0 * m; i < n * m && ok; i++) ok = lab[i] >= 0 && lab[i] < nc;
        const int64_t *path = b[0].view.buf;
        for (Py_ssize_t i = 0; i < (n - k0) * m && ok; i++) ok = path[i] >= 0 && path[i] < m;
        if (!ok) {
            PyErr_SetString(PyExc_ValueError, "path_clusters: a label or particle index out of range");
        } else {
            Py_BEGIN_ALLOW_THREADS
            path_clusters(n, m, k0, nc, path, b[1].view.buf, lab, b[3].view.buf, b[4].view.buf, b[5].view.buf,
                          b[6].view.buf, work, work + m);
            Py_END_ALLOW_THREADS
            res = Py_None;
            Py_INCREF(res);
        }
        PyMem_RawFree(work);
    }
    release(b, 7);
    return res;
}

/* The complementary filter's loop (sportfusion.climbing.orientation.complementary_filter, same operations
 * in the same order): R_k+1 = R_k Exp((w_k + e_k) dT_k) with the correction e_k = ka_k f_k x R_k^T u +
 * km_k h_k x R_k^T m (unit specific force f, unit field h, gains 0 where not trusted); rows (n, 9) of R,
 * each made orthonormal at the end. */
static void complementary(int64_t n, const double *f, const double *h, const double *w, const double *ka,
                          const double *km, const double *dt, const double *r_start, const double *up,
                          const double *mw, double *rows) {
    double r0 = r_start[0], r1 = r_start[1], r2 = r_start[2], r3 = r_start[3], r4 = r_start[4], r5 = r_start[5];
    double r6 = r_start[6], r7 = r_start[7], r8 = r_start[8];
    const double ux = up[0], uy = up[1], uz = up[2], mx = mw[0], my = mw[1], mz = mw[2];
    memcpy(rows, r_start, 9 * sizeof(double));
    for (int64_t k = 0; k + 1 < n; k++) {
        const double fx = f[3 * k], fy = f[3 * k + 1], fz = f[3 * k + 2];
        const double hx = h[3 * k], hy = h[3 * k + 1], hz = h[3 * k + 2];
        const double a = ka[k], m_ = km[k], d = dt[k];
        double bx = r0 * ux + r3 * uy + r6 * uz, by = r1 * ux + r4 * uy + r7 * uz, bz = r2 * ux + r5 * uy + r8 * uz;
        double cx = r0 * mx + r3 * my + r6 * mz, cy = r1 * mx + r4 * my + r7 * mz, cz = r2 * mx + r5 * my + r8 * mz;
        double ex = a * (fy * bz - fz * by) + m_ * (hy * cz - hz * cy);
        double ey = a * (fz * bx - fx * bz) + m_ * (hz * cx - hx * cz);
        double ez = a * (fx * by - fy * bx) + m_ * (hx * cy - hy * cx);
        double px = (w[3 * k] + ex) * d, py = (w[3 * k + 1] + ey) * d, pz = (w[3 * k + 2] + ez) * d;
        double th2 = px * px + py * py + pz * pz, sa, sb;
        if (th2 < 1e-18) {
            sa = 1.0, sb = 0.5;
        } else {
            double th = sqrt(th2);
            sa = sin(th) / th, sb = (1.0 - cos(th)) / th2;
        }
        double e0 = 1.0 - sb * (py * py + pz * pz), e4 = 1.0 - sb * (px * px + pz * pz);
        double e8 = 1.0 - sb * (px * px + py * py);
        double e1 = -sa * pz + sb * px * py, e3 = sa * pz + sb * px * py;
        double e2 = sa * py + sb * px * pz, e6 = -sa * py + sb * px * pz;
        double e5 = -sa * px + sb * py * pz, e7 = sa * px + sb * py * pz;
        double n0 = r0 * e0 + r1 * e3 + r2 * e6, n1 = r0 * e1 + r1 * e4 + r2 * e7, n2 = r0 * e2 + r1 * e5 + r2 * e8;
        double n3 = r3 * e0 + r4 * e3 + r5 * e6, n4 = r3 * e1 + r4 * e4 + r5 * e7, n5 = r3 * e2 + r4 * e5 + r5 * e8;
        double n6 = r6 * e0 + r7 * e3 + r8 * e6, n7 = r6 * e1 + r7 * e4 + r8 * e7, n8 = r6 * e2 + r7 * e5 + r8 * e8;
        r0 = n0, r1 = n1, r2 = n2, r3 = n3, r4 = n4, r5 = n5, r6 = n6, r7 = n7, r8 = n8;
        double *out = rows + 9 * (k + 1);
        out[0] = r0, out[1] = r1, out[2] = r2, out[3] = r3, out[4] = r4, out[5] = r5, out[6] = r6, out[7] = r7;
        out[8] = r8;
    }
    /* the rotations nearest to the rows (rounding drift over thousands of products): the polar factor by
     * Newton's iteration R <- (R + R^-T) / 2, quadratic from a matrix this close to a rotation (what the
     * numpy path gets from an SVD, u vt) */
    for (int64_t k = 0; k < n; k++) {
        double *a = rows + 9 * k;
        for (int it = 0; it < 2; it++) {
            /* R^-T = cofactor(R) / det(R) */
            double c0 = a[4] * a[8] - a[5] * a[7], c1 = a[5] * a[6] - a[3] * a[8], c2 = a[3] * a[7] - a[4] * a[6];
            double c3 = a[2] * a[7] - a[1] * a[8], c4 = a[0] * a[8] - a[2] * a[6], c5 = a[1] * a[6] - a[0] * a[7];
            double c6 = a[1] * a[5] - a[2] * a[4], c7 = a[2] * a[3] - a[0] * a[5], c8 = a[0] * a[4] - a[1] * a[3];
            double det = a[0] * c0 + a[1] * c1 + a[2] * c2, h = 0.5 / det;
            a[0] = 0.5 * a[0] + h * c0, a[1] = 0.5 * a[1] + h * c1, a[2] = 0.5 * a[2] + h * c2;
            a[3] = 0.5 * a[3] + h * c3, a[4] = 0.5 * a[4] + h * c4, a[5] = 0.5 * a[5] + h * c5;
            a[6] = 0.5 * a[6] + h * c6, a[7] = 0.5 * a[7] + h * c7, a[8] = 0.5 * a[8] + h * c8;
        }
    }
}

static PyObject *py_complementary(PyObject *self, PyObject *args) {
    long long n;
    PyObject *o[10];
    if (!PyArg_ParseTuple(args, "LOOOOOOOOOO", &n, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9]))
        return NULL;
    if (n < 1) {
        PyErr_SetString(PyExc_ValueError, "complementary: bad dimensions (needs n >= 1)");
        return NULL;
    }
    static const char *names[10] = {"f", "h", "w", "ka", "km", "dt", "r0", "up", "m_world", "rows"};
    const Py_ssize_t n1 = n - 1 > 0 ? n - 1 : 0;
    Py_ssize_t cnt[10] = {-3 * n1, -3 * n1, -3 * n1, -n1, -n1, n1, 9, 3, 3, 9 * n};
    Buf b[10];
    memset(b, 0, sizeof(b));
    int k;
    for (k = 0; k < 10; k++) {
        if (n1 == 0 && k < 6) continue;
        if (get_buf(o[k], &b[k], cnt[k], k == 9, names[k]) < 0) break;
    }
    PyObject *res = NULL;
    if (k == 10) {
        void *p[10];
        for (int i = 0; i < 10; i++) p[i] = b[i].held ? b[i].view.buf : NULL;
        Py_BEGIN_ALLOW_THREADS
        complementary(n, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9]);
        Py_END_ALLOW_THREADS
        res = Py_None;
        Py_INCREF(res);
    }
    release(b, 10);
    return res;
}

/* ---- the transition estimator's Levenberg-Marquardt blocks (transition.py: linearize, normal_equations) ----
 * The dynamic model's whitened residuals and Jacobian blocks per step, and their contributions to the normal
 * equations, in one pass over the samples (numpy forms each as a batch of small matrix products).  The
 * SO(3) helpers follow climbing._so3 / core.rotations step by step: Exp through the unit quaternion (series of
 * sin(x/2)/x below 1e-4 rad, normalised), Log through Shepperd's quaternion and atan2, the right Jacobian and
 * its inverse in closed form with series below 1e-5 rad. */

static void so3_exp(const double *phi, double R[3][3]) {
    double th = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]);
    double k = th < 1e-4 ? 0.5 - th * th / 48.0 : sin(0.5 * th) / th;
    double q0 = cos(0.5 * th), q1 = k * phi[0], q2 = k * phi[1], q3 = k * phi[2];
    double nq = sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3);
    double M[3][3];
    quat_mbo(q0 / nq, q1 / nq, q2 / nq, q3 / nq, M);
    for (int i = 0; i < 3; i++) /* R(q) = M_BO(q)^T */
        for (int j = 0; j < 3; j++) R[i][j] = M[j][i];
}

static void so3_log(double R[3][3], double *out) {
    double tr = R[0][0] + R[1][1] + R[2][2], cand[4] = {tr, R[0][0], R[1][1], R[2][2]}, q[4], s;
    int k = 0;
    for (int i = 1; i < 4; i++)
        if (cand[i] > cand[k]) k = i;
    if (k == 0) {
        s = sqrt(fmax(1.0 + tr, 0.0)) * 2;
        q[0] = 0.25 * s, q[1] = (R[2][1] - R[1][2]) / s, q[2] = (R[0][2] - R[2][0]) / s, q[3] = (R[1][0] - R[0][1]) / s;
    } else if (k == 1) {
        s = sqrt(fmax(1.0 + R[0][0] - R[1][1] - R[2][2], 0.0)) * 2;
        q[0] = (R[2][1] - R[1][2]) / s, q[1] = 0.25 * s, q[2] = (R[0][1] + R[1][0]) / s, q[3] = (R[0][2] + R[2][0]) / s;
    } else if (k == 2) {
        s = sqrt(fmax(1.0 + R[1][1] - R[0][0] - R[2][2], 0.0)) * 2;
        q[0] = (R[0][2] - R[2][0]) / s, q[1] = (R[0][1] + R[1][0]) / s, q[2] = 0.25 * s, q[3] = (R[1][2] + R[2][1]) / s;
    } else {
        s = sqrt(fmax(1.0 + R[2][2] - R[0][0] - R[1][1], 0.0)) * 2;
        q[0] = (R[1][0] - R[0][1]) / s, q[1] = (R[0][2] + R[2][0]) / s, q[2] = (R[1][2] + R[2][1]) / s, q[3] = 0.25 * s;
    }
    double nq = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) q[i] /= nq;
    if (q[0] < 0)
        for (int i = 0; i < 4; i++) q[i] = -q[i];
    double sv = sqrt(q[1] * q[1] + q[2] * q[2] + q[3] * q[3]), th = 2.0 * atan2(sv, q[0]);
    double kk = sv < 1e-8 ? 2.0 / fmax(q[0], 1e-300) : th / sv;
    for (int i = 0; i < 3; i++) out[i] = kk * q[i + 1];
}

static void hat3(const double *v, double K[3][3]) {
    K[0][0] = 0.0, K[0][1] = -v[2], K[0][2] = v[1];
    K[1][0] = v[2], K[1][1] = 0.0, K[1][2] = -v[0];
    K[2][0] = -v[1], K[2][1] = v[0], K[2][2] = 0.0;
}

static void mul3(double A[3][3], double B[3][3], double C[3][3]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[i][j] = A[i][0] * B[0][j] + A[i][1] * B[1][j] + A[i][2] * B[2][j];
}

/* I + a K + b K^2 with K = hat(phi): the right Jacobian (inverse: 0) or its inverse (1) */
static void so3_jr(const double *phi, int inverse, double J[3][3]) {
    double th = sqrt(phi[0] * phi[0] + phi[1] * phi[1] + phi[2] * phi[2]), K[3][3], K2[3][3], a, b;
    int small = th < 1e-5;
    double ts = small ? 1.0 : th;
    if (inverse) {
        a = 0.5;
        b = small ? 1.0 / 12.0 : 1.0 / (ts * ts) - (1.0 + cos(ts)) / (2.0 * ts * sin(ts));
    } else {
        a = -(small ? 0.5 : (1.0 - cos(ts)) / (ts * ts));
        b = small ? 1.0 / 6.0 : (ts - sin(ts)) / (ts * ts * ts);
    }
    hat3(phi, K);
    mul3(K, K, K2);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) J[i][j] = (i == j ? 1.0 : 0.0) + a * K[i][j] + b * K2[i][j];
}

/* per step k < m: whitened r_dyn (6), ja, jb (6 x 6), jc (6 x 9) as transition.linearize */
static void transition_blocks(int64_t m, const double *dt, const double *gyr, const double *acc, const double *r,
                              const double *v, const double *b, const double *sig, const double *g, double *r_dyn,
                              double *ja, double *jb, double *jc) {
    for (int64_t k = 0; k < m; k++) {
        double d = dt[k], phi[3], f[3], E[3][3], R0[3][3], R1[3][3], T[3][3], RE[3][3], rr[3], Ji[3][3], Jr[3][3];
        double Hf[3][3], RH[3][3], M[3][3], w[6], res[6];
        for (int i = 0; i < 3; i++) {
            phi[i] = (gyr[3 * k + i] - b[3 + i]) * d;
            f[i] = acc[3 * k + i] - b[i];
        }
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                R0[i][j] = r[9 * k + 3 * i + j];
                R1[i][j] = r[9 * (k + 1) + 3 * i + j];
            }
        so3_exp(phi, E);
        for (int i = 0; i < 3; i++) /* R1^T R0 */
            for (int j = 0; j < 3; j++) T[i][j] = R1[0][i] * R0[0][j] + R1[1][i] * R0[1][j] + R1[2][i] * R0[2][j];
        mul3(T, E, RE);
        so3_log(RE, rr);
        for (int i = 0; i < 3; i++) {
            double rf = R0[i][0] * f[0] + R0[i][1] * f[1] + R0[i][2] * f[2];
            res[i] = rr[i];
            res[3 + i] = v[3 * k + i] + d * (rf + g[i]) - v[3 * (k + 1) + i];
        }
        for (int i = 0; i < 6; i++) {
            r_dyn[6 * k + i] = res[i] / sig[6 * k + i];
            w[i] = 1.0 / sig[6 * k + i];
        }
        so3_jr(rr, 1, Ji);
        so3_jr(phi, 0, Jr);
        hat3(f, Hf);
        mul3(R0, Hf, RH);
        double *A = ja + 36 * k, *B = jb + 36 * k, *C = jc + 54 * k;
        memset(A, 0, 36 * sizeof(double));
        memset(B, 0, 36 * sizeof(double));
        memset(C, 0, 54 * sizeof(double));
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                A[6 * i + j] = (Ji[i][0] * E[j][0] + Ji[i][1] * E[j][1] + Ji[i][2] * E[j][2]) * w[i]; /* Jinv E^T */
                A[6 * (3 + i) + j] = (-d * RH[i][j]) * w[3 + i];
                B[6 * i + j] = (-Ji[i][0] * RE[j][0] - Ji[i][1] * RE[j][1] - Ji[i][2] * RE[j][2]) * w[i];
                C[9 * (3 + i) + j] = (-d * R0[i][j]) * w[3 + i];
            }
        mul3(Ji, Jr, M);
        for (int i = 0; i < 3; i++) {
            for (int j = 0; j < 3; j++) C[9 * i + 3 + j] = (-M[i][j] * d) * w[i];
            A[6 * (3 + i) + 3 + i] = w[3 + i];
            B[6 * (3 + i) + 3 + i] = -w[3 + i];
        }
    }
}

/* the dynamic model's part of J^T J and J^T r (transition.normal_equations): hd (n x 36) and hxb (n x 54),
   gx (n x 6) accumulated from zero, ho (m x 36) set, hbb (81) and gb (9) summed over the steps */
static void normal_blocks(int64_t m, const double *ja, const double *jb, const double *jc, const double *r_dyn,
                          double *hd, double *ho, double *hxb, double *hbb, double *gx, double *gb) {
    memset(hd, 0, 36 * (m + 1) * sizeof(double));
    memset(hxb, 0, 54 * (m + 1) * sizeof(double));
    memset(gx, 0, 6 * (m + 1) * sizeof(double));
    memset(hbb, 0, 81 * sizeof(double));
    memset(gb, 0, 9 * sizeof(double));
    for (int64_t k = 0; k < m; k++) {
        const double *A = ja + 36 * k, *B = jb + 36 * k, *C = jc + 54 * k, *r = r_dyn + 6 * k;
        double *h0 = hd + 36 * k, *h1 = hd + 36 * (k + 1), *o = ho + 36 * k;
        double *x0 = hxb + 54 * k, *x1 = hxb + 54 * (k + 1), *g0 = gx + 6 * k, *g1 = gx + 6 * (k + 1);
        for (int i = 0; i < 6; i++) {
            double sa[6] = {0}, sb[6] = {0}, sab[6] = {0}, ca[9] = {0}, cb[9] = {0}, ga = 0.0, gbv = 0.0;
            for (int l = 0; l < 6; l++) {
                double a = A[6 * l + i], bb = B[6 * l + i];
                for (int j = 0; j < 6; j++) {
                    sa[j] += a * A[6 * l + j];
                    sb[j] += bb * B[6 * l + j];
                    sab[j] += a * B[6 * l + j];
                }
                for (int j = 0; j < 9; j++) {
                    ca[j] += a * C[9 * l + j];
                    cb[j] += bb * C[9 * l + j];
                }
                ga += a * r[l];
                gbv += bb * r[l];
            }
            for (int j = 0; j < 6; j++) {
                h0[6 * i + j] += sa[j];
                h1[6 * i + j] += sb[j];
                o[6 * i + j] = sab[j];
            }
            for (int j = 0; j < 9; j++) {
                x0[9 * i + j] += ca[j];
                x1[9 * i + j] += cb[j];
            }
            g0[i] += ga;
            g1[i] += gbv;
        }
        for (int l = 0; l < 6; l++) {
            const double *c = C + 9 * l;
            for (int i = 0; i < 9; i++) {
                for (int j = 0; j < 9; j++) hbb[9 * i + j] += c[i] * c[j];
                gb[i] += c[i] * r[l];
            }
        }
    }
}

static PyObject *py_transition_blocks(PyObject *self, PyObject *args) {
    long long m;
    PyObject *o[12];
    if (!PyArg_ParseTuple(args, "LOOOOOOOOOOOO", &m, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9], &o[10], &o[11]))
        return NULL;
    if (m < 1) {
        PyErr_SetString(PyExc_ValueError, "transition_blocks: m must be at least 1");
        return NULL;
    }
    static const char *names[12] = {"dt", "gyr", "acc", "r", "v", "b", "sig_dyn", "g_world", "r_dyn", "ja", "jb", "jc"};
    Py_ssize_t cnt[12] = {m, -3 * m, -3 * m, 9 * (m + 1), 3 * (m + 1), 9, 6 * m, 3, 6 * m, 36 * m, 36 * m, 54 * m};
    Buf b[12];
    int k;
    for (k = 0; k < 12; k++)
        if (get_buf(o[k], &b[k], cnt[k], k >= 8, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 12) {
        const double *p[8];
        for (int i = 0; i < 8; i++) p[i] = b[i].view.buf;
        Py_BEGIN_ALLOW_THREADS
        transition_blocks(m, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], b[8].view.buf, b[9].view.buf,
                          b[10].view.buf, b[11].view.buf);
        Py_END_ALLOW_THREADS
        Py_INCREF(Py_None);
        res = Py_None;
    }
    release(b, k < 12 ? k + 1 : 12);
    return res;
}

static PyObject *py_normal_blocks(PyObject *self, PyObject *args) {
    long long m;
    PyObject *o[10];
    if (!PyArg_ParseTuple(args, "LOOOOOOOOOO", &m, &o[0], &o[1], &o[2], &o[3], &o[4], &o[5], &o[6], &o[7], &o[8],
                          &o[9]))
        return NULL;
    if (m < 1) {
        PyErr_SetString(PyExc_ValueError, "normal_blocks: m must be at least 1");
        return NULL;
    }
    static const char *names[10] = {"ja", "jb", "jc", "r_dyn", "hd", "ho", "hxb", "hbb", "gx", "gb"};
    Py_ssize_t cnt[10] = {36 * m, 36 * m, 54 * m, 6 * m, 36 * (m + 1), 36 * m, 54 * (m + 1), 81, 6 * (m + 1), 9};
    Buf b[10];
    int k;
    for (k = 0; k < 10; k++)
        if (get_buf(o[k], &b[k], cnt[k], k >= 4, names[k]) < 0) break;
    PyObject *res = NULL;
    if (k == 10) {
        Py_BEGIN_ALLOW_THREADS
        normal_blocks(m, b[0].view.buf, b[1].view.buf, b[2].view.buf, b[3].view.buf, b[4].view.buf, b[5].view.buf,
                      b[6].view.buf, b[7].view.buf, b[8].view.buf, b[9].view.buf);
        Py_END_ALLOW_THREADS
        Py_INCREF(Py_None);
        res = Py_None;
    }
    release(b, k < 10 ? k + 1 : 10);
    return res;
}

static PyMethodDef methods[] = {
    {"path_clusters", py_path_clusters, METH_VARARGS, "The smoother's most likely cluster per step from its paths."},
    {"complementary", py_complementary, METH_VARARGS, "The complementary filter's loop (see orientation.py)."},
    {"forward", py_forward, METH_VARARGS, "The climbing particle filter's forward pass (see particles.py)."},
    {"backward_paths", py_paths, METH_VARARGS, "Backward-simulation trajectories of eq 17's transition density."},
    {"transition_blocks", py_transition_blocks, METH_VARARGS,
     "transition_blocks(m, dt, gyr, acc, r, v, b, sig_dyn, g_world, r_dyn, ja, jb, jc): the dynamic model's\n"
     "whitened residuals and Jacobian blocks of transition.linearize, written into the last four (float64)."},
    {"normal_blocks", py_normal_blocks, METH_VARARGS,
     "normal_blocks(m, ja, jb, jc, r_dyn, hd, ho, hxb, hbb, gx, gb): the dynamic model's part of\n"
     "transition.normal_equations (J^T J blocks and J^T r), written into the last six (float64)."},
    {NULL, NULL, 0, NULL},
};

static struct PyModuleDef module = {
    PyModuleDef_HEAD_INIT, "_climbing_c", "pf-holds' loops in C: particle filter, backward simulation, complementary filter, transition blocks.",
    -1, methods,
};

PyMODINIT_FUNC PyInit__climbing_c(void) { return PyModule_Create(&module); }
