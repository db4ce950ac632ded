// Kernels of solver/linalg/sweeps.py (the supernodal sweeps y <- U^{-1} L^{-1} y and the gather /
// scatter of the right-hand sides) and solver/linalg/supernodal.py (the layout of a factor in
// supernode blocks: subtree sizes, column statistics, rows below, transpose, block fill).
//
// The layout (see solver/linalg/sweeps.py): per supernode s of columns starts[s]..starts[s+1]-1,
// the rows R below its diagonal block (from rstart[s]), the off-diagonal blocks LB and UB
// (L[R, c0:c1]^T and U[c0:c1, R], row-major, from bstart[s]), the diagonal blocks LD and UD (from
// dstart[s]) and the inverted diagonals ldinv and udinv. The sweeps run in the factor's precision
// T (float or double), accumulations included; indices are int64.
#include "common.h"

#include <algorithm>
#include <vector>

namespace tmc {

namespace {

using I = int64_t;

template <class T>
using Arr3 = nb::ndarray<T, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

// ---------------------------------------------------------------------------------------------
// Sweeps over three right-hand sides, y (3, n): each a contiguous vector y0, y1, y2.

// Row a of a diagonal block: y_q[c0 + a] = (y_q[c0 + a] - D[base + lo:base + hi] . y_q[c0 + lo:c0 + hi]) g.
// The forward sweep takes [0, a) of the lower block, the backward (a, w) of the upper one.
template <class T>
inline void diag_row3(const T *__restrict D, I base, I lo, I hi, T g, I c0, I a, T *__restrict y0,
                      T *__restrict y1, T *__restrict y2) {
    T a0 = 0, a1 = 0, a2 = 0;
    const T *__restrict d = D + base + lo;
    const T *__restrict x0 = y0 + c0 + lo;
    const T *__restrict x1 = y1 + c0 + lo;
    const T *__restrict x2 = y2 + c0 + lo;
    const I m = hi - lo;
#pragma omp simd simdlen(4) reduction(+ : a0, a1, a2)
    for (I e = 0; e < m; ++e) {
        const T v = d[e];
        a0 += v * x0[e];
        a1 += v * x1[e];
        a2 += v * x2[e];
    }
    y0[c0 + a] = (y0[c0 + a] - a0) * g;
    y1[c0 + a] = (y1[c0 + a] - a1) * g;
    y2[c0 + a] = (y2[c0 + a] - a2) * g;
}

template <class T>
struct Factor {
    const I *starts, *rstart, *R, *bstart, *dstart;
    const T *B, *D, *dinv;  // one triangle: LB, LD, ldinv or UB, UD, udinv
};

inline I max_rows(const I *rstart, I s_lo, I s_hi) {
    I maxr = 0;
    for (I s = s_lo; s < s_hi; ++s) maxr = std::max(maxr, rstart[s + 1] - rstart[s]);
    return maxr;
}

// y <- L^{-1} y over supernodes s_lo..s_hi-1; updates of columns >= top go to acc (3, n - top) instead.
template <class T>
void forward3(const Factor<T> &f, I s_lo, I s_hi, T *y0, T *y1, T *y2, T *acc0, T *acc1, T *acc2, I top) {
    const I maxr = max_rows(f.rstart, s_lo, s_hi);
    std::vector<T> tbuf(3 * std::max<I>(maxr, 1));
    T *__restrict t0 = tbuf.data();
    T *__restrict t1 = t0 + maxr;
    T *__restrict t2 = t1 + maxr;
    const T *__restrict LB = f.B;
    for (I s = s_lo; s < s_hi; ++s) {
        const I c0 = f.starts[s];
        const I w = f.starts[s + 1] - c0;
        const I r0 = f.rstart[s];
        const I r = f.rstart[s + 1] - r0;
        for (I a = 0; a < w; ++a) diag_row3(f.D, f.dstart[s] + a * w, I(0), a, f.dinv[c0 + a], c0, a, y0, y1, y2);
        if (r == 0) continue;
        std::fill(t0, t0 + r, T(0));
        std::fill(t1, t1 + r, T(0));
        std::fill(t2, t2 + r, T(0));
        I a = 0;
        I b = f.bstart[s];
        while (a + 4 <= w) {  // four block columns per pass over t: a quarter of its loads and stores
            const I c = c0 + a;
            const T p0 = y0[c], p1 = y0[c + 1], p2 = y0[c + 2], p3 = y0[c + 3];
            const T q0 = y1[c], q1 = y1[c + 1], q2 = y1[c + 2], q3 = y1[c + 3];
            const T u0 = y2[c], u1 = y2[c + 1], u2 = y2[c + 2], u3 = y2[c + 3];
            const T *__restrict L0 = LB + b;
            const T *__restrict L1 = L0 + r;
            const T *__restrict L2 = L1 + r;
            const T *__restrict L3 = L2 + r;
#pragma omp simd
            for (I i = 0; i < r; ++i) {
                const T v0 = L0[i], v1 = L1[i], v2 = L2[i], v3 = L3[i];
                t0[i] += p0 * v0 + p1 * v1 + p2 * v2 + p3 * v3;
                t1[i] += q0 * v0 + q1 * v1 + q2 * v2 + q3 * v3;
                t2[i] += u0 * v0 + u1 * v1 + u2 * v2 + u3 * v3;
            }
            a += 4;
            b += 4 * r;
        }
        while (a < w) {  // the last one to three columns
            const T p0 = y0[c0 + a], q0 = y1[c0 + a], u0 = y2[c0 + a];
            const T *__restrict L0 = LB + b;
#pragma omp simd
            for (I i = 0; i < r; ++i) {
                const T v0 = L0[i];
                t0[i] += p0 * v0;
                t1[i] += q0 * v0;
                t2[i] += u0 * v0;
            }
            a += 1;
            b += r;
        }
        const I *rows = f.R + r0;
        for (I i = 0; i < r; ++i) {
            const I k = rows[i];
            if (k < top) {
                y0[k] -= t0[i];
                y1[k] -= t1[i];
                y2[k] -= t2[i];
            } else {
                acc0[k - top] += t0[i];
                acc1[k - top] += t1[i];
                acc2[k - top] += t2[i];
            }
        }
    }
}

// y <- U^{-1} y over supernodes s_hi-1 down to s_lo (later columns already solved): the values below
// a supernode are gathered once into three vectors, and each block row is a dot product with them.
template <class T>
void backward3(const Factor<T> &f, I s_lo, I s_hi, T *__restrict y0, T *__restrict y1, T *__restrict y2) {
    const I maxr = max_rows(f.rstart, s_lo, s_hi);
    std::vector<T> gbuf(3 * std::max<I>(maxr, 1));
    T *__restrict g0 = gbuf.data();
    T *__restrict g1 = g0 + maxr;
    T *__restrict g2 = g1 + maxr;
    const T *__restrict UB = f.B;
    for (I s = s_hi - 1; s >= s_lo; --s) {
        const I c0 = f.starts[s];
        const I w = f.starts[s + 1] - c0;
        const I r0 = f.rstart[s];
        const I r = f.rstart[s + 1] - r0;
        if (r) {
            const I *rows = f.R + r0;
            for (I i = 0; i < r; ++i) {
                const I k = rows[i];
                g0[i] = y0[k];
                g1[i] = y1[k];
                g2[i] = y2[k];
            }
            I a = 0;
            I b = f.bstart[s];
            while (a + 4 <= w) {  // four block rows per pass over the gathered values
                const T *__restrict U0 = UB + b;
                const T *__restrict U1 = U0 + r;
                const T *__restrict U2 = U1 + r;
                const T *__restrict U3 = U2 + r;
                T s00 = 0, s01 = 0, s02 = 0, s10 = 0, s11 = 0, s12 = 0;
                T s20 = 0, s21 = 0, s22 = 0, s30 = 0, s31 = 0, s32 = 0;
#pragma omp simd reduction(+ : s00, s01, s02, s10, s11, s12, s20, s21, s22, s30, s31, s32)
                for (I i = 0; i < r; ++i) {
                    const T e0 = g0[i], e1 = g1[i], e2 = g2[i];
                    const T u0 = U0[i], u1 = U1[i], u2 = U2[i], u3 = U3[i];
                    s00 += u0 * e0;
                    s01 += u0 * e1;
                    s02 += u0 * e2;
                    s10 += u1 * e0;
                    s11 += u1 * e1;
                    s12 += u1 * e2;
                    s20 += u2 * e0;
                    s21 += u2 * e1;
                    s22 += u2 * e2;
                    s30 += u3 * e0;
                    s31 += u3 * e1;
                    s32 += u3 * e2;
                }
                const I c = c0 + a;
                y0[c] -= s00;
                y1[c] -= s01;
                y2[c] -= s02;
                y0[c + 1] -= s10;
                y1[c + 1] -= s11;
                y2[c + 1] -= s12;
                y0[c + 2] -= s20;
                y1[c + 2] -= s21;
                y2[c + 2] -= s22;
                y0[c + 3] -= s30;
                y1[c + 3] -= s31;
                y2[c + 3] -= s32;
                a += 4;
                b += 4 * r;
            }
            while (a < w) {  // the last one to three rows
                const T *__restrict U0 = UB + b;
                T a0 = 0, a1 = 0, a2 = 0;
#pragma omp simd reduction(+ : a0, a1, a2)
                for (I i = 0; i < r; ++i) {
                    const T u = U0[i];
                    a0 += u * g0[i];
                    a1 += u * g1[i];
                    a2 += u * g2[i];
                }
                y0[c0 + a] -= a0;
                y1[c0 + a] -= a1;
                y2[c0 + a] -= a2;
                a += 1;
                b += r;
            }
        }
        for (I a = w - 1; a >= 0; --a)
            diag_row3(f.D, f.dstart[s] + a * w, a + 1, w, f.dinv[c0 + a], c0, a, y0, y1, y2);
    }
}

// Supernodes [lo, hi) of one of the two subtrees that split cuts.
inline void part_range(const I *split, int part, I &lo, I &hi) {
    lo = part == 0 ? 0 : split[0];
    hi = part == 0 ? split[0] : split[1];
}

template <class T>
void sweep3(Vec<const I> starts, Vec<const I> rstart, Vec<const I> R, Vec<const I> bstart, Vec<const T> LB,
            Vec<const T> UB, Vec<const I> dstart, Vec<const T> LD, Vec<const T> UD, Vec<const T> ldinv,
            Vec<const T> udinv, Vec<const I> split_, Mat<T> y_) {
    const Factor<T> L{starts.data(), rstart.data(), R.data(), bstart.data(), dstart.data(),
                      LB.data(),     LD.data(),     ldinv.data()};
    const Factor<T> U{starts.data(), rstart.data(), R.data(), bstart.data(), dstart.data(),
                      UB.data(),     UD.data(),     udinv.data()};
    const I *split = split_.data();
    const I n = I(y_.shape(1));
    const I ns = I(starts.shape(0)) - 1;
    T *y0 = y_.data(), *y1 = y0 + n, *y2 = y1 + n;
    if (split[0] == 0) {  // no cut: one thread, no buffers for the top
        forward3(L, I(0), ns, y0, y1, y2, (T *)nullptr, (T *)nullptr, (T *)nullptr, n);
        backward3(U, I(0), ns, y0, y1, y2);
        return;
    }
    const I top = starts.data()[split[1]];
    const I m = n - top;
    std::vector<T> acc(size_t(2 * 3 * m), T(0));
#pragma omp parallel for schedule(static)
    for (int part = 0; part < 2; ++part) {
        I lo, hi;
        part_range(split, part, lo, hi);
        T *a = acc.data() + part * 3 * m;
        forward3(L, lo, hi, y0, y1, y2, a, a + m, a + 2 * m, top);
    }
    for (int q = 0; q < 3; ++q) {
        T *yq = y0 + q * n + top;
        const T *a0 = acc.data() + q * m;
        const T *a1 = acc.data() + (3 + q) * m;
#pragma omp simd
        for (I k = 0; k < m; ++k) yq[k] -= a0[k] + a1[k];
    }
    forward3(L, split[1], ns, y0, y1, y2, acc.data(), acc.data() + m, acc.data() + 2 * m, n);
    backward3(U, split[1], ns, y0, y1, y2);
#pragma omp parallel for schedule(static)
    for (int part = 0; part < 2; ++part) {
        I lo, hi;
        part_range(split, part, lo, hi);
        backward3(U, lo, hi, y0, y1, y2);
    }
}

// ---------------------------------------------------------------------------------------------
// Sweeps over any number of right-hand sides, y (n, k): every inner loop runs over the k
// contiguous columns of a row, so each factor entry is read once for all of them.

// diag_row3 for y of shape (n, k).
template <class T>
inline void diag_row(const T *D, I base, I lo, I hi, T g, I c0, I a, T *y, I k) {
    T *__restrict ya = y + (c0 + a) * k;
    for (I e = lo; e < hi; ++e) {
        const T v = D[base + e];
        const T *__restrict ye = y + (c0 + e) * k;
#pragma omp simd
        for (I q = 0; q < k; ++q) ya[q] -= v * ye[q];
    }
#pragma omp simd
    for (I q = 0; q < k; ++q) ya[q] *= g;
}

template <class T>
void forward_wide(const Factor<T> &f, I s_lo, I s_hi, T *y, I k, T *acc, I top) {
    for (I s = s_lo; s < s_hi; ++s) {
        const I c0 = f.starts[s];
        const I w = f.starts[s + 1] - c0;
        const I r0 = f.rstart[s];
        const I r = f.rstart[s + 1] - r0;
        for (I a = 0; a < w; ++a) diag_row(f.D, f.dstart[s] + a * w, I(0), a, f.dinv[c0 + a], c0, a, y, k);
        for (I a = 0; a < w; ++a) {
            const I base = f.bstart[s] + a * r;
            const T *__restrict ya = y + (c0 + a) * k;
            for (I i = 0; i < r; ++i) {
                const T v = f.B[base + i];
                const I row = f.R[r0 + i];
                if (row < top) {
                    T *__restrict yr = y + row * k;
#pragma omp simd
                    for (I q = 0; q < k; ++q) yr[q] -= v * ya[q];
                } else {
                    T *__restrict ar = acc + (row - top) * k;
#pragma omp simd
                    for (I q = 0; q < k; ++q) ar[q] += v * ya[q];
                }
            }
        }
    }
}

template <class T>
void backward_wide(const Factor<T> &f, I s_lo, I s_hi, T *y, I k) {
    std::vector<T> tbuf(std::max<I>(k, 1));
    T *__restrict t = tbuf.data();
    for (I s = s_hi - 1; s >= s_lo; --s) {
        const I c0 = f.starts[s];
        const I w = f.starts[s + 1] - c0;
        const I r0 = f.rstart[s];
        const I r = f.rstart[s + 1] - r0;
        for (I a = 0; a < w; ++a) {
            const I base = f.bstart[s] + a * r;
            std::fill(t, t + k, T(0));
            for (I i = 0; i < r; ++i) {
                const T u = f.B[base + i];
                const T *__restrict yr = y + f.R[r0 + i] * k;
#pragma omp simd
                for (I q = 0; q < k; ++q) t[q] += u * yr[q];
            }
            T *__restrict ya = y + (c0 + a) * k;
#pragma omp simd
            for (I q = 0; q < k; ++q) ya[q] -= t[q];
        }
        for (I a = w - 1; a >= 0; --a) diag_row(f.D, f.dstart[s] + a * w, a + 1, w, f.dinv[c0 + a], c0, a, y, k);
    }
}

template <class T>
void sweep_wide(Vec<const I> starts, Vec<const I> rstart, Vec<const I> R, Vec<const I> bstart, Vec<const T> LB,
                Vec<const T> UB, Vec<const I> dstart, Vec<const T> LD, Vec<const T> UD, Vec<const T> ldinv,
                Vec<const T> udinv, Vec<const I> split_, Mat<T> y_) {
    const Factor<T> L{starts.data(), rstart.data(), R.data(), bstart.data(), dstart.data(),
                      LB.data(),     LD.data(),     ldinv.data()};
    const Factor<T> U{starts.data(), rstart.data(), R.data(), bstart.data(), dstart.data(),
                      UB.data(),     UD.data(),     udinv.data()};
    const I *split = split_.data();
    const I n = I(y_.shape(0)), k = I(y_.shape(1));
    const I ns = I(starts.shape(0)) - 1;
    T *y = y_.data();
    if (split[0] == 0) {  // no cut: one thread, no buffers for the top
        forward_wide(L, I(0), ns, y, k, (T *)nullptr, n);
        backward_wide(U, I(0), ns, y, k);
        return;
    }
    const I top = starts.data()[split[1]];
    const I m = (n - top) * k;
    std::vector<T> acc(size_t(2 * m), T(0));
#pragma omp parallel for schedule(static)
    for (int part = 0; part < 2; ++part) {
        I lo, hi;
        part_range(split, part, lo, hi);
        forward_wide(L, lo, hi, y, k, acc.data() + part * m, top);
    }
    {
        T *yt = y + top * k;
        const T *a0 = acc.data();
        const T *a1 = acc.data() + m;
#pragma omp simd
        for (I e = 0; e < m; ++e) yt[e] -= a0[e] + a1[e];
    }
    forward_wide(L, split[1], ns, y, k, acc.data(), n);
    backward_wide(U, split[1], ns, y, k);
#pragma omp parallel for schedule(static)
    for (int part = 0; part < 2; ++part) {
        I lo, hi;
        part_range(split, part, lo, hi);
        backward_wide(U, lo, hi, y, k);
    }
}

// y[q // 3, q % 3, i] = B[perm[i], q]: the permuted right-hand sides, three per sweep (y (g, 3, n)
// is contiguous, so y[q // 3, q % 3, i] is y.flat[q * n + i]).
template <class T>
void gather(Mat<const double> B_, Vec<const I> perm_, Arr3<T> y_) {
    const I n = I(B_.shape(0)), k = I(B_.shape(1));
    const double *B = B_.data();
    const I *perm = perm_.data();
    T *y = y_.data();
    for (I i = 0; i < n; ++i) {
        const double *src = B + perm[i] * k;
        for (I q = 0; q < k; ++q) y[q * n + i] = T(src[q]);
    }
}

// X[perm[i], q] = y[q // 3, q % 3, i].
template <class T>
void scatter(Arr3<const T> y_, Vec<const I> perm_, Mat<double> X_) {
    const I n = I(X_.shape(0)), k = I(X_.shape(1));
    const T *y = y_.data();
    const I *perm = perm_.data();
    double *X = X_.data();
    for (I i = 0; i < n; ++i) {
        double *dst = X + perm[i] * k;
        for (I q = 0; q < k; ++q) dst[q] = double(y[q * n + i]);
    }
}

// ---------------------------------------------------------------------------------------------
// The layout (solver/linalg/supernodal.py).

// Size and smallest column of every column's subtree (parents come after their children).
void subtrees(Vec<const I> parent_, Vec<I> size_, Vec<I> lo_) {
    const I n = I(parent_.shape(0));
    const I *parent = parent_.data();
    I *size = size_.data(), *lo = lo_.data();
    for (I c = 0; c < n; ++c) {
        size[c] = 1;
        lo[c] = c;
    }
    for (I c = 0; c < n; ++c) {
        const I p = parent[c];
        if (p >= 0) {
            size[p] += size[c];
            lo[p] = std::min(lo[p], lo[c]);
        }
    }
}

// First row below the diagonal of every column (-1 when none) and how many rows lie below it.
void column_stats(Vec<const I> Lp_, Vec<const I> Li_, Vec<I> first_, Vec<I> below_) {
    const I n = I(Lp_.shape(0)) - 1;
    const I *Lp = Lp_.data(), *Li = Li_.data();
    I *first = first_.data(), *below = below_.data();
    for (I c = 0; c < n; ++c) {
        I m = n, cnt = 0;
        for (I p = Lp[c]; p < Lp[c + 1]; ++p) {
            const I r = Li[p];
            if (r > c) {
                ++cnt;
                if (r < m) m = r;
            }
        }
        below[c] = cnt;
        first[c] = m < n ? m : -1;
    }
}

// R: for every supernode, the rows below the diagonal of its last column.
void rows_below(Vec<const I> starts_, Vec<const I> Lp_, Vec<const I> Li_, Vec<const I> rstart_, Vec<I> R_) {
    const I ns = I(starts_.shape(0)) - 1;
    const I *starts = starts_.data(), *Lp = Lp_.data(), *Li = Li_.data(), *rstart = rstart_.data();
    I *R = R_.data();
    for (I s = 0; s < ns; ++s) {
        const I c = starts[s + 1] - 1;
        I k = rstart[s];
        for (I p = Lp[c]; p < Lp[c + 1]; ++p)
            if (Li[p] > c) R[k++] = Li[p];
    }
}

// CSC of U^T (the rows of U) from the CSC of U, by a counting sort: Tp (n + 1,), Ti and Tx (nnz,).
void transpose(Vec<const I> Up_, Vec<const I> Ui_, Vec<const double> Ux_, Vec<I> Tp_, Vec<I> Ti_,
               Vec<double> Tx_) {
    const I n = I(Up_.shape(0)) - 1;
    const I *Up = Up_.data(), *Ui = Ui_.data();
    const double *Ux = Ux_.data();
    I *Tp = Tp_.data(), *Ti = Ti_.data();
    double *Tx = Tx_.data();
    const I nnz = Up[n];
    std::fill(Tp, Tp + n + 1, I(0));
    for (I p = 0; p < nnz; ++p) Tp[Ui[p] + 1] += 1;
    for (I i = 0; i < n; ++i) Tp[i + 1] += Tp[i];
    std::vector<I> nxt(Tp, Tp + n);
    for (I c = 0; c < n; ++c) {
        for (I p = Up[c]; p < Up[c + 1]; ++p) {
            const I q = nxt[Ui[p]]++;
            Ti[q] = c;
            Tx[q] = Ux[p];
        }
    }
}

// Scatter one triangle's columns (lower: L by columns; else U^T by columns) into the blocks B, D and
// the inverted diagonal dinv. False when an entry falls outside its supernode's pattern.
bool fill(Vec<const I> starts_, Vec<const I> Lp_, Vec<const I> Li_, Vec<const double> Lx_, bool lower,
          Vec<const I> rstart_, Vec<const I> R_, Vec<const I> bstart_, Vec<const I> dstart_, Vec<double> B_,
          Vec<double> D_, Vec<double> dinv_) {
    const I n = I(Lp_.shape(0)) - 1;
    const I ns = I(starts_.shape(0)) - 1;
    const I *starts = starts_.data(), *Lp = Lp_.data(), *Li = Li_.data(), *rstart = rstart_.data();
    const I *R = R_.data(), *bstart = bstart_.data(), *dstart = dstart_.data();
    const double *Lx = Lx_.data();
    double *B = B_.data(), *D = D_.data(), *dinv = dinv_.data();
    std::vector<I> where(size_t(std::max<I>(n, 0)), I(-1));
    for (I s = 0; s < ns; ++s) {
        const I c0 = starts[s], c1 = starts[s + 1];
        const I w = c1 - c0;
        const I r0 = rstart[s], r = rstart[s + 1] - rstart[s];
        for (I i = 0; i < r; ++i) where[R[r0 + i]] = i;
        for (I c = c0; c < c1; ++c) {
            const I a = c - c0;
            for (I p = Lp[c]; p < Lp[c + 1]; ++p) {
                const I row = Li[p];
                const double v = Lx[p];
                if (row == c) {
                    if (v == 0.0) return false;
                    dinv[c] = 1.0 / v;
                } else if (row < c) {
                    return false;
                } else if (row < c1) {
                    const I e = row - c0;
                    if (lower)
                        D[dstart[s] + e * w + a] = v;
                    else
                        D[dstart[s] + a * w + e] = v;
                } else {
                    const I i = where[row];
                    if (i < 0) return false;
                    B[bstart[s] + a * r + i] = v;
                }
            }
        }
        for (I i = 0; i < r; ++i) where[R[r0 + i]] = -1;
    }
    return true;
}

// Every supernode's (w, w) diagonal block of D, transposed into out.
void transpose_blocks(Vec<const I> starts_, Vec<const I> dstart_, Vec<const double> D_, Vec<double> out_) {
    const I ns = I(starts_.shape(0)) - 1;
    const I *starts = starts_.data(), *dstart = dstart_.data();
    const double *D = D_.data();
    double *out = out_.data();
    for (I s = 0; s < ns; ++s) {
        const I w = starts[s + 1] - starts[s];
        const I d0 = dstart[s];
        for (I a = 0; a < w; ++a)
            for (I e = 0; e < w; ++e) out[d0 + a * w + e] = D[d0 + e * w + a];
    }
}

template <class T>
void register_precision(nb::module_ &m) {
    m.def("sweeps_sweep3", &sweep3<T>, nb::arg("starts"), nb::arg("rstart"), nb::arg("R"), nb::arg("bstart"),
          nb::arg("LB"), nb::arg("UB"), nb::arg("dstart"), nb::arg("LD"), nb::arg("UD"), nb::arg("ldinv"),
          nb::arg("udinv"), nb::arg("split"), nb::arg("y").noconvert(), Release(),
          "y <- U^{-1} L^{-1} y for three right-hand sides, y (3, n), in the factor's precision.");
    m.def("sweeps_sweep_wide", &sweep_wide<T>, nb::arg("starts"), nb::arg("rstart"), nb::arg("R"),
          nb::arg("bstart"), nb::arg("LB"), nb::arg("UB"), nb::arg("dstart"), nb::arg("LD"), nb::arg("UD"),
          nb::arg("ldinv"), nb::arg("udinv"), nb::arg("split"), nb::arg("y").noconvert(), Release(),
          "y <- U^{-1} L^{-1} y for y (n, k), any k, in the factor's precision.");
    m.def("sweeps_gather", &gather<T>, nb::arg("B"), nb::arg("perm"), nb::arg("y").noconvert(), Release(),
          "y[q // 3, q % 3, i] = B[perm[i], q]; B (n, k) float64, y (g, 3, n).");
    m.def("sweeps_scatter", &scatter<T>, nb::arg("y"), nb::arg("perm"), nb::arg("X").noconvert(), Release(),
          "X[perm[i], q] = y[q // 3, q % 3, i]; y (g, 3, n), X (n, k) float64.");
}

}  // namespace

void register_sweeps(nb::module_ &m) {
    register_precision<float>(m);
    register_precision<double>(m);
    m.def("supernodal_subtrees", &subtrees, nb::arg("parent"), nb::arg("size").noconvert(),
          nb::arg("lo").noconvert(), Release(),
          "Size and smallest column of every column's subtree (parents after their children).");
    m.def("supernodal_column_stats", &column_stats, nb::arg("Lp"), nb::arg("Li"), nb::arg("first").noconvert(),
          nb::arg("below").noconvert(), Release(),
          "First row below the diagonal of every column (-1 when none) and the number of rows below it.");
    m.def("supernodal_rows_below", &rows_below, nb::arg("starts"), nb::arg("Lp"), nb::arg("Li"), nb::arg("rstart"),
          nb::arg("R").noconvert(), Release(), "R: every supernode's rows below the diagonal of its last column.");
    m.def("supernodal_transpose", &transpose, nb::arg("Up"), nb::arg("Ui"), nb::arg("Ux"), nb::arg("Tp").noconvert(),
          nb::arg("Ti").noconvert(), nb::arg("Tx").noconvert(), Release(), "CSC of U^T from the CSC of U.");
    m.def("supernodal_fill", &fill, nb::arg("starts"), nb::arg("Lp"), nb::arg("Li"), nb::arg("Lx"),
          nb::arg("lower"), nb::arg("rstart"), nb::arg("R"), nb::arg("bstart"), nb::arg("dstart"),
          nb::arg("B").noconvert(), nb::arg("D").noconvert(), nb::arg("dinv").noconvert(), Release(),
          "Scatter one triangle's columns into the supernode blocks; False when an entry is outside the pattern.");
    m.def("supernodal_transpose_blocks", &transpose_blocks, nb::arg("starts"), nb::arg("dstart"), nb::arg("D"),
          nb::arg("out").noconvert(), Release(), "Every supernode's diagonal block of D, transposed into out.");
}

}  // namespace tmc
