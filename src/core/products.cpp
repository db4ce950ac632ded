// Kernels of solver/linalg/products.py (fused sparse products of narrow blocks), residual.py
// (residuals of blocks of right-hand sides with their largest row norms) and layout.py (tiled copies
// between row- and column-major blocks). Each loops over rows (or chunks of rows) in parallel, with
// the same sums in the same order per row as a row-by-row CSR product.
#include "common.h"

#include <nanobind/stl/vector.h>

#include <algorithm>
#include <type_traits>
#include <vector>

// No fused multiply-adds in this file: every a * b + c rounds twice, as in a plain CSR product, so the
// results do not depend on which loops the compiler happens to contract (nor on the index type).
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace tmc {
namespace {

template <class T>
using CVec = Vec<const T>;
template <class T>
using CMat = Mat<const T>;
template <class T>
using CFMat = FMat<const T>;
template <class T>
using CArr3 = nb::ndarray<const T, nb::ndim<3>, nb::c_contig, nb::device::cpu>;

// ---------------------------------------------------------------------------------------------
// products.py

// The loops below take the width of a block (K) as a template argument where it is the usual 3 (one
// position array): a loop of three known steps, unrolled, in place of a vector loop sized at run time
// for three elements. K = 0: the width read from the arrays.
template <int64_t K>
inline int64_t width_of(int64_t k) {
    return K > 0 ? K : k;
}

// out[:, block j] = c[j] - A x[:, block j] row by row, c of shape (k, l, w).
template <int64_t K, class I>
void residual_rows_stacked_k(CVec<I> indptr, CVec<I> indices, CVec<double> data, CArr3<double> c, CMat<double> x,
                             Mat<double> out) {
    const int64_t n = out.shape(0), m = width_of<K>(out.shape(1));
    const int64_t k = c.shape(0), l = c.shape(1), w = c.shape(2), xs = x.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const double *ad = data.data(), *cd = c.data(), *xd = x.data();
    double *od = out.data();
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        double *__restrict o = od + i * m;
        if constexpr (K > 0) {  // one block (k = 1, w = K): the sums in registers
            double acc[K];
            for (int64_t q = 0; q < K; ++q) acc[q] = cd[i * K + q];
            for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
                const double v = ad[p];
                const double *xr = xd + int64_t(ix[p]) * xs;
                for (int64_t q = 0; q < K; ++q) acc[q] -= v * xr[q];
            }
            for (int64_t q = 0; q < K; ++q) o[q] = acc[q];
        } else {
            for (int64_t j = 0; j < k; ++j)
                for (int64_t q = 0; q < w; ++q) o[j * w + q] = cd[(j * l + i) * w + q];
            const int64_t hi = ip[i + 1];
            int64_t p = ip[i];
            for (; p + 1 < hi; p += 2) {  // two entries per pass over the row, each element in the same order
                const double v = ad[p], u = ad[p + 1];
                const double *__restrict xr = xd + int64_t(ix[p]) * xs;
                const double *__restrict yr = xd + int64_t(ix[p + 1]) * xs;
#pragma omp simd
                for (int64_t q = 0; q < m; ++q) o[q] = o[q] - v * xr[q] - u * yr[q];
            }
            if (p < hi) {
                const double v = ad[p];
                const double *__restrict xr = xd + int64_t(ix[p]) * xs;
#pragma omp simd
                for (int64_t q = 0; q < m; ++q) o[q] -= v * xr[q];
            }
        }
    }
}

template <class I>
void residual_rows_stacked(CVec<I> indptr, CVec<I> indices, CVec<double> data, CArr3<double> c, CMat<double> x,
                           Mat<double> out) {
    if (out.shape(1) == 3 && c.shape(0) == 1)
        residual_rows_stacked_k<3>(indptr, indices, data, c, x, out);
    else
        residual_rows_stacked_k<0>(indptr, indices, data, c, x, out);
}

// out = A x row by row.
template <int64_t K, class I>
void product_rows_k(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> x, Mat<double> out) {
    const int64_t n = out.shape(0), k = width_of<K>(out.shape(1)), xs = x.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const double *ad = data.data(), *xd = x.data();
    double *od = out.data();
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        double *__restrict o = od + i * k;
        if constexpr (K > 0) {  // the sums in registers
            double acc[K];
            for (int64_t q = 0; q < K; ++q) acc[q] = 0.0;
            for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
                const double v = ad[p];
                const double *xr = xd + int64_t(ix[p]) * xs;
                for (int64_t q = 0; q < K; ++q) acc[q] += v * xr[q];
            }
            for (int64_t q = 0; q < K; ++q) o[q] = acc[q];
        } else {
            for (int64_t q = 0; q < k; ++q) o[q] = 0.0;
            const int64_t hi = ip[i + 1];
            int64_t p = ip[i];
            for (; p + 1 < hi; p += 2) {  // two entries per pass over the row, each element in the same order
                const double v = ad[p], u = ad[p + 1];
                const double *__restrict xr = xd + int64_t(ix[p]) * xs;
                const double *__restrict yr = xd + int64_t(ix[p + 1]) * xs;
#pragma omp simd
                for (int64_t q = 0; q < k; ++q) o[q] = o[q] + v * xr[q] + u * yr[q];
            }
            if (p < hi) {
                const double v = ad[p];
                const double *__restrict xr = xd + int64_t(ix[p]) * xs;
#pragma omp simd
                for (int64_t q = 0; q < k; ++q) o[q] += v * xr[q];
            }
        }
    }
}

template <class I>
void product_rows(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> x, Mat<double> out) {
    if (out.shape(1) == 3)
        product_rows_k<3>(indptr, indices, data, x, out);
    else
        product_rows_k<0>(indptr, indices, data, x, out);
}

// out = r0 + M (P[cols] - rest) row by row.
template <int64_t K, class I>
void shifted_rows_k(CVec<I> indptr, CVec<I> indices, CVec<double> data, CVec<int64_t> cols, CMat<double> P,
                    CMat<double> rest, CMat<double> r0, Mat<double> out) {
    const int64_t n = out.shape(0), k = width_of<K>(out.shape(1));
    const int64_t ps = P.shape(1), rs = rest.shape(1), r0s = r0.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const int64_t *cl = cols.data();
    const double *ad = data.data(), *pd = P.data(), *rd = rest.data(), *r0d = r0.data();
    double *od = out.data();
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        double *__restrict o = od + i * k;
        if constexpr (K > 0) {  // the sums in registers
            double acc[K];
            for (int64_t q = 0; q < K; ++q) acc[q] = r0d[i * r0s + q];
            for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
                const double v = ad[p];
                const int64_t j = ix[p];
                const double *pr = pd + cl[j] * ps, *rr = rd + j * rs;
                for (int64_t q = 0; q < K; ++q) acc[q] += v * (pr[q] - rr[q]);
            }
            for (int64_t q = 0; q < K; ++q) o[q] = acc[q];
        } else {
            for (int64_t q = 0; q < k; ++q) o[q] = r0d[i * r0s + q];
            for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
                const double v = ad[p];
                const int64_t j = ix[p];
                const double *__restrict pr = pd + cl[j] * ps;
                const double *__restrict rr = rd + j * rs;
#pragma omp simd
                for (int64_t q = 0; q < k; ++q) o[q] += v * (pr[q] - rr[q]);
            }
        }
    }
}

template <class I>
void shifted_rows(CVec<I> indptr, CVec<I> indices, CVec<double> data, CVec<int64_t> cols, CMat<double> P,
                  CMat<double> rest, CMat<double> r0, Mat<double> out) {
    if (out.shape(1) == 3)
        shifted_rows_k<3>(indptr, indices, data, cols, P, rest, r0, out);
    else
        shifted_rows_k<0>(indptr, indices, data, cols, P, rest, r0, out);
}

// out[:, block j] = r0 + M D[:, block j] row by row, blocks of r0's width.
template <class I>
void offset_rows(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> D, CMat<double> r0,
                 Mat<double> out) {
    const int64_t n = out.shape(0), m = out.shape(1), w = r0.shape(1), ds = D.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const double *ad = data.data(), *dd = D.data(), *r0d = r0.data();
    double *od = out.data();
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        double *__restrict o = od + i * m;
        const double *r = r0d + i * w;
        for (int64_t b = 0; b < m; b += w)
            for (int64_t q = 0; q < w; ++q) o[b + q] = r[q];
        for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
            const double v = ad[p];
            const double *__restrict dr = dd + int64_t(ix[p]) * ds;
#pragma omp simd
            for (int64_t q = 0; q < m; ++q) o[q] += v * dr[q];
        }
    }
}

// D[:, w j:w (j + 1)] = Ps[j][cols] - rest for every j, D row-major (FORTRAN false) or column-major: one
// pass over the rows of D.
template <bool FORTRAN, int64_t K, class DArr>
void stacked_differences_k(const std::vector<CMat<double>> &Ps, CVec<int64_t> cols, CMat<double> rest, DArr D) {
    const int64_t c = cols.shape(0), w = width_of<K>(rest.shape(1)), np_ = int64_t(Ps.size());
    const int64_t rows = D.shape(0), ncol = D.shape(1);
    std::vector<const double *> pd(static_cast<size_t>(np_));
    std::vector<int64_t> ps(static_cast<size_t>(np_));
    for (int64_t j = 0; j < np_; ++j) {
        pd[j] = Ps[j].data();
        ps[j] = Ps[j].shape(1);
    }
    const int64_t *cl = cols.data();
    const double *rd = rest.data();
    double *dd = D.data();
    if constexpr (FORTRAN) {  // array by array: each thread writes w runs of its rows per array
#pragma omp parallel
        for (int64_t j = 0; j < np_; ++j) {
            const double *pj = pd[j];
            const int64_t sj = ps[j];
#pragma omp for schedule(static) nowait
            for (int64_t i = 0; i < c; ++i) {
                const double *pr = pj + cl[i] * sj, *rr = rd + i * w;
                for (int64_t q = 0; q < w; ++q) dd[(w * j + q) * rows + i] = pr[q] - rr[q];
            }
        }
    } else {  // row by row: each row of D written whole, once
        (void)rows;
#pragma omp parallel for schedule(static)
        for (int64_t i = 0; i < c; ++i) {
            const double *rr = rd + i * w;
            const int64_t g = cl[i];
            double *o = dd + i * ncol;
            for (int64_t j = 0; j < np_; ++j) {
                const double *pr = pd[j] + g * ps[j];
                for (int64_t q = 0; q < w; ++q) o[w * j + q] = pr[q] - rr[q];
            }
        }
    }
}

template <bool FORTRAN, class DArr>
void stacked_differences(std::vector<CMat<double>> Ps, CVec<int64_t> cols, CMat<double> rest, DArr D) {
    if (rest.shape(1) == 3)
        stacked_differences_k<FORTRAN, 3>(Ps, cols, rest, D);
    else
        stacked_differences_k<FORTRAN, 0>(Ps, cols, rest, D);
}

// out = W C row by row, summed in float64 whatever W's and out's precision.
template <class TW, class TO>
void combine_rows(CMat<TW> W, CMat<double> C, Mat<TO> out) {
    const int64_t n = out.shape(0), m = out.shape(1), r = W.shape(1);
    const TW *wd = W.data();
    const double *cd = C.data();
    TO *od = out.data();
#pragma omp parallel
    {
        std::vector<double> buf(size_t(std::max<int64_t>(m, 1)));
        double *__restrict acc = buf.data();
#pragma omp for schedule(static)
        for (int64_t i = 0; i < n; ++i) {
            for (int64_t q = 0; q < m; ++q) acc[q] = 0.0;
            int64_t t = 0;
            for (; t + 1 < r; t += 2) {  // two columns of W per pass over acc, each element in the same order
                const double w = double(wd[i * r + t]), v = double(wd[i * r + t + 1]);
                const double *__restrict cr = cd + t * m, *__restrict dr = cr + m;
#pragma omp simd
                for (int64_t q = 0; q < m; ++q) acc[q] = acc[q] + w * cr[q] + v * dr[q];
            }
            if (t < r) {
                const double w = double(wd[i * r + t]);
                const double *__restrict cr = cd + t * m;
#pragma omp simd
                for (int64_t q = 0; q < m; ++q) acc[q] += w * cr[q];
            }
            TO *o = od + i * m;
            for (int64_t q = 0; q < m; ++q) o[q] = TO(acc[q]);
        }
    }
}

// ---------------------------------------------------------------------------------------------
// residual.py

// acc += sign * A[i] X: one sparse row times the dense block.
template <class I, class TX>
inline void axpy_row(const I *ip, const I *ix, const double *ad, const TX *xd, int64_t xs, int64_t i, double sign,
                     double *__restrict acc, int64_t m) {
    const int64_t hi = ip[i + 1];
    int64_t p = ip[i];
    for (; p + 1 < hi; p += 2) {  // two entries per pass over acc, each element summed in the same order
        const double a = sign * ad[p], b = sign * ad[p + 1];
        const TX *__restrict xr = xd + int64_t(ix[p]) * xs;
        const TX *__restrict yr = xd + int64_t(ix[p + 1]) * xs;
#pragma omp simd
        for (int64_t j = 0; j < m; ++j) acc[j] = acc[j] + a * double(xr[j]) + b * double(yr[j]);
    }
    if (p < hi) {
        const double a = sign * ad[p];
        const TX *__restrict xr = xd + int64_t(ix[p]) * xs;
#pragma omp simd
        for (int64_t j = 0; j < m; ++j) acc[j] += a * double(xr[j]);
    }
}

// Row i's residual acc (stored in its row of R when STORE): the largest squared norms per block so far,
// rmc and xmc (the chunk's); W > 0: the block width known. A NaN row's value is taken (NaN is not <= the
// maximum), but the next row's replaces it again: a NaN is reported only from a chunk's last row (as
// the former kernels did). A float32 X is squared in float32.
template <bool STORE, int64_t W, class TX>
inline void tally_row(const double *__restrict acc, const TX *__restrict xr, int64_t m, int64_t width,
                      double *__restrict rrow, double *__restrict rmc, double *__restrict xmc) {
    const int64_t w = width_of<W>(width);
    for (int64_t b = 0; b < m / w; ++b) {
        double r2 = 0.0, x2 = 0.0;
        for (int64_t q = b * w; q < (b + 1) * w; ++q) {
            if constexpr (STORE) rrow[q] = acc[q];
            r2 += acc[q] * acc[q];
            const TX x = xr[q];
            x2 += double(x * x);  // squared in X's precision
        }
        if (!(r2 <= rmc[b])) rmc[b] = r2;
        if (!(x2 <= xmc[b])) xmc[b] = x2;
    }
}

// R = B - A X per chunk of rows (rmax.shape[0] chunks), with the chunk's largest squared row norms of
// R and X per block of width columns.
template <bool STORE, int64_t W, class I, class TX>
void residual_kernel_k(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> B, CMat<TX> X,
                       int64_t width, Mat<double> R, Mat<double> rmax, Mat<double> xmax) {
    const int64_t n = B.shape(0), m = B.shape(1), nch = rmax.shape(0), nb = rmax.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const double *ad = data.data(), *bd = B.data();
    const TX *xd = X.data();
    double *rd = R.data(), *rm = rmax.data(), *xm = xmax.data();
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        std::vector<double> buf(size_t(m + 2 * nb));
        double *acc = buf.data(), *rmc = acc + m, *xmc = rmc + nb;
        std::copy(rm + c * nb, rm + (c + 1) * nb, rmc);
        std::copy(xm + c * nb, xm + (c + 1) * nb, xmc);
        for (int64_t i = c * n / nch; i < (c + 1) * n / nch; ++i) {
            for (int64_t j = 0; j < m; ++j) acc[j] = bd[i * m + j];
            axpy_row(ip, ix, ad, xd, m, i, -1.0, acc, m);
            tally_row<STORE, W>(acc, xd + i * m, m, width, STORE ? rd + i * m : nullptr, rmc, xmc);
        }
        std::copy(rmc, rmc + nb, rm + c * nb);
        std::copy(xmc, xmc + nb, xm + c * nb);
    }
}

template <class I, class TX>
void residual_kernel(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> B, CMat<TX> X, int64_t width,
                     bool store, Mat<double> R, Mat<double> rmax, Mat<double> xmax) {
    if (store && width == 3)
        residual_kernel_k<true, 3>(indptr, indices, data, B, X, width, R, rmax, xmax);
    else if (store)
        residual_kernel_k<true, 0>(indptr, indices, data, B, X, width, R, rmax, xmax);
    else if (width == 3)
        residual_kernel_k<false, 3>(indptr, indices, data, B, X, width, R, rmax, xmax);
    else
        residual_kernel_k<false, 0>(indptr, indices, data, B, X, width, R, rmax, xmax);
}

// residual_kernel's norms for B = r0 + M D (r0 in every block), B never stored.
template <int64_t W, class IA, class IM, class TX>
void coupled_residual_kernel_k(CVec<IA> ai, CVec<IA> aj, CVec<double> ax, CVec<IM> mi, CVec<IM> mj, CVec<double> mx,
                               CMat<double> r0, CMat<double> D, CMat<TX> X, int64_t width, Mat<double> rmax,
                               Mat<double> xmax) {
    const int64_t n = X.shape(0), m = D.shape(1), nch = rmax.shape(0), nb = rmax.shape(1), w = width_of<W>(width);
    const IA *aip = ai.data(), *aix = aj.data();
    const IM *mip = mi.data(), *mix = mj.data();
    const double *ad = ax.data(), *md = mx.data(), *r0d = r0.data(), *dd = D.data();
    const TX *xd = X.data();
    double *rm = rmax.data(), *xm = xmax.data();
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        std::vector<double> buf(size_t(m + 2 * nb));
        double *acc = buf.data(), *rmc = acc + m, *xmc = rmc + nb;
        std::copy(rm + c * nb, rm + (c + 1) * nb, rmc);
        std::copy(xm + c * nb, xm + (c + 1) * nb, xmc);
        for (int64_t i = c * n / nch; i < (c + 1) * n / nch; ++i) {
            const double *r = r0d + i * w;
            for (int64_t b = 0; b < m; b += w)
                for (int64_t q = 0; q < w; ++q) acc[b + q] = r[q];
            axpy_row(mip, mix, md, dd, m, i, 1.0, acc, m);
            axpy_row(aip, aix, ad, xd, m, i, -1.0, acc, m);
            tally_row<false, W>(acc, xd + i * m, m, w, nullptr, rmc, xmc);
        }
        std::copy(rmc, rmc + nb, rm + c * nb);
        std::copy(xmc, xmc + nb, xm + c * nb);
    }
}

template <class IA, class IM, class TX>
void coupled_residual_kernel(CVec<IA> ai, CVec<IA> aj, CVec<double> ax, CVec<IM> mi, CVec<IM> mj, CVec<double> mx,
                             CMat<double> r0, CMat<double> D, CMat<TX> X, int64_t width, Mat<double> rmax,
                             Mat<double> xmax) {
    if (width == 3)
        coupled_residual_kernel_k<3>(ai, aj, ax, mi, mj, mx, r0, D, X, width, rmax, xmax);
    else
        coupled_residual_kernel_k<0>(ai, aj, ax, mi, mj, mx, r0, D, X, width, rmax, xmax);
}

// residual_kernel for one block of three columns (one update), with the sums in registers.
template <class I, class TX>
void residual3_kernel(CVec<I> indptr, CVec<I> indices, CVec<double> data, CMat<double> B, CMat<TX> X, bool store,
                      Mat<double> R, Mat<double> rmax, Mat<double> xmax) {
    const int64_t n = B.shape(0), nch = rmax.shape(0), rs = rmax.shape(1);
    const I *ip = indptr.data(), *ix = indices.data();
    const double *ad = data.data(), *bd = B.data();
    const TX *xd = X.data();
    double *rd = R.data(), *rm = rmax.data(), *xm = xmax.data();
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        double rmx = 0.0, xmx = 0.0;
        for (int64_t i = c * n / nch; i < (c + 1) * n / nch; ++i) {
            double a0 = bd[3 * i], a1 = bd[3 * i + 1], a2 = bd[3 * i + 2];
            for (int64_t p = ip[i]; p < int64_t(ip[i + 1]); ++p) {
                const double v = ad[p];
                const TX *xr = xd + 3 * int64_t(ix[p]);
                a0 -= v * double(xr[0]);
                a1 -= v * double(xr[1]);
                a2 -= v * double(xr[2]);
            }
            if (store) {
                rd[3 * i] = a0;
                rd[3 * i + 1] = a1;
                rd[3 * i + 2] = a2;
            }
            const double r2 = a0 * a0 + a1 * a1 + a2 * a2;
            const TX x0 = xd[3 * i], x1 = xd[3 * i + 1], x2_ = xd[3 * i + 2];
            const double x2 = double(x0 * x0 + x1 * x1 + x2_ * x2_);  // summed in X's precision
            if (!(r2 <= rmx)) rmx = r2;  // as tally_row (NaN included)
            if (!(x2 <= xmx)) xmx = x2;
        }
        rm[c * rs] = rmx;
        xm[c * rs] = xmx;
    }
}

// Q[rows[r]] -= X[r, col:col + w] (rows distinct).
template <int64_t K, class TX>
void subtract_rows_k(Mat<double> Q, CVec<int64_t> rows, CMat<TX> X, int64_t col) {
    const int64_t w = width_of<K>(Q.shape(1)), f = rows.shape(0), xs = X.shape(1);
    double *qd = Q.data();
    const int64_t *rw = rows.data();
    const TX *xd = X.data();
#pragma omp parallel for schedule(static)
    for (int64_t r = 0; r < f; ++r) {
        double *q = qd + rw[r] * w;
        const TX *x = xd + r * xs + col;
        if constexpr (K == 3) {  // scalar: a vector loop of three elements is slower
            const double q0 = q[0] - double(x[0]), q1 = q[1] - double(x[1]), q2 = q[2] - double(x[2]);
            q[0] = q0;
            q[1] = q1;
            q[2] = q2;
        } else {
            for (int64_t a = 0; a < w; ++a) q[a] -= double(x[a]);
        }
    }
}

template <class TX>
void subtract_rows(Mat<double> Q, CVec<int64_t> rows, CMat<TX> X, int64_t col) {
    if (Q.shape(1) == 3)
        subtract_rows_k<3>(Q, rows, X, col);
    else
        subtract_rows_k<0>(Q, rows, X, col);
}

// ---------------------------------------------------------------------------------------------
// layout.py

// dst = src (same shape, one row-major and one column-major) in tiles of rows: within a tile one array
// is walked along its columns and the other stays in cache.
template <class S, class D, class SrcArr, class DstArr>
void copy_tiles(SrcArr src, DstArr dst, int64_t tile) {
    constexpr bool src_c = std::is_same_v<SrcArr, CMat<S>>;
    const int64_t n = src.shape(0), k = src.shape(1);
    const S *sd = src.data();
    D *dd = dst.data();
    const int64_t ntiles = tile > 0 ? (n + tile - 1) / tile : 0;
#pragma omp parallel for schedule(static)
    for (int64_t t = 0; t < ntiles; ++t) {
        const int64_t lo = t * tile, hi = std::min(lo + tile, n);
        for (int64_t j = 0; j < k; ++j) {
            if constexpr (src_c) {
                D *__restrict o = dd + j * n;
                const S *__restrict s = sd + j;
                for (int64_t i = lo; i < hi; ++i) o[i] = D(s[i * k]);
            } else {
                D *__restrict o = dd + j;
                const S *__restrict s = sd + j * n;
                for (int64_t i = lo; i < hi; ++i) o[i * k] = D(s[i]);
            }
        }
    }
}

// ---------------------------------------------------------------------------------------------
// bindings, one overload per dtype combination the callers pass

template <class I>
void bind_index(nb::module_ &m) {
    m.def("products_residual_rows_stacked", &residual_rows_stacked<I>, nb::arg("indptr"), nb::arg("indices"),
          nb::arg("data"), nb::arg("c"), nb::arg("x"), nb::arg("out").noconvert(), Release(),
          "out[:, block j] = c[j] - A x[:, block j] for CSR A and c of shape (k, l, w).");
    m.def("products_product_rows", &product_rows<I>, nb::arg("indptr"), nb::arg("indices"), nb::arg("data"),
          nb::arg("x"), nb::arg("out").noconvert(), Release(), "out = A x for CSR A.");
    m.def("products_shifted_rows", &shifted_rows<I>, nb::arg("indptr"), nb::arg("indices"), nb::arg("data"),
          nb::arg("cols"), nb::arg("P"), nb::arg("rest"), nb::arg("r0"), nb::arg("out").noconvert(), Release(),
          "out = r0 + M (P[cols] - rest) for CSR M.");
    m.def("products_offset_rows", &offset_rows<I>, nb::arg("indptr"), nb::arg("indices"), nb::arg("data"),
          nb::arg("D"), nb::arg("r0"), nb::arg("out").noconvert(), Release(),
          "out[:, block j] = r0 + M D[:, block j] for CSR M, blocks of r0's width.");
    m.def("products_residual", &residual_kernel<I, double>, nb::arg("indptr"), nb::arg("indices"), nb::arg("data"),
          nb::arg("B"), nb::arg("X"), nb::arg("width"), nb::arg("store"), nb::arg("R").noconvert(),
          nb::arg("rmax").noconvert(), nb::arg("xmax").noconvert(), Release(),
          "R = B - A X (stored if store) and, per chunk of rows (rmax.shape[0]) and block of width columns, "
          "the largest squared row norms of R and X into rmax and xmax.");
    m.def("products_residual", &residual_kernel<I, float>, nb::arg("indptr"), nb::arg("indices"), nb::arg("data"),
          nb::arg("B"), nb::arg("X"), nb::arg("width"), nb::arg("store"), nb::arg("R").noconvert(),
          nb::arg("rmax").noconvert(), nb::arg("xmax").noconvert(), Release());
    m.def("products_residual3", &residual3_kernel<I, double>, nb::arg("indptr"), nb::arg("indices"),
          nb::arg("data"), nb::arg("B"), nb::arg("X"), nb::arg("store"), nb::arg("R").noconvert(),
          nb::arg("rmax").noconvert(), nb::arg("xmax").noconvert(), Release(),
          "products_residual for one block of three columns.");
    m.def("products_residual3", &residual3_kernel<I, float>, nb::arg("indptr"), nb::arg("indices"),
          nb::arg("data"), nb::arg("B"), nb::arg("X"), nb::arg("store"), nb::arg("R").noconvert(),
          nb::arg("rmax").noconvert(), nb::arg("xmax").noconvert(), Release());
}

template <class IA, class IM, class TX>
void bind_coupled(nb::module_ &m) {
    m.def("products_coupled_residual", &coupled_residual_kernel<IA, IM, TX>, nb::arg("ai"), nb::arg("aj"),
          nb::arg("ax"), nb::arg("mi"), nb::arg("mj"), nb::arg("mx"), nb::arg("r0"), nb::arg("D"), nb::arg("X"),
          nb::arg("width"), nb::arg("rmax").noconvert(), nb::arg("xmax").noconvert(), Release(),
          "products_residual's norms for B = r0 + M D (r0 in every block of width columns), B never formed.");
}

template <class TW, class TO>
void bind_combine(nb::module_ &m) {
    m.def("products_combine_rows", &combine_rows<TW, TO>, nb::arg("W"), nb::arg("C"), nb::arg("out").noconvert(),
          Release(), "out = W C, summed in float64.");
}

template <class S, class D>
void bind_copy(nb::module_ &m) {
    m.def("products_copy_tiles", &copy_tiles<S, D, CMat<S>, FMat<D>>, nb::arg("src"), nb::arg("dst").noconvert(),
          nb::arg("tile"), Release(), "dst = src, row-major to column-major (or back), in tiles of rows.");
    m.def("products_copy_tiles", &copy_tiles<S, D, CFMat<S>, Mat<D>>, nb::arg("src"), nb::arg("dst").noconvert(),
          nb::arg("tile"), Release());
}

}  // namespace

void register_products(nb::module_ &m) {
    bind_index<int32_t>(m);
    bind_index<int64_t>(m);
    bind_coupled<int32_t, int32_t, double>(m);
    bind_coupled<int32_t, int32_t, float>(m);
    bind_coupled<int64_t, int64_t, double>(m);
    bind_coupled<int64_t, int64_t, float>(m);
    bind_coupled<int32_t, int64_t, double>(m);
    bind_coupled<int32_t, int64_t, float>(m);
    bind_coupled<int64_t, int32_t, double>(m);
    bind_coupled<int64_t, int32_t, float>(m);
    m.def("products_stacked_differences", &stacked_differences<false, Mat<double>>, nb::arg("Ps"), nb::arg("cols"),
          nb::arg("rest"), nb::arg("D").noconvert(), Release(),
          "D[:, w j:w (j + 1)] = Ps[j][cols] - rest for each (n, w) array of the list Ps, D row- or column-major.");
    m.def("products_stacked_differences", &stacked_differences<true, FMat<double>>, nb::arg("Ps"), nb::arg("cols"),
          nb::arg("rest"), nb::arg("D").noconvert(), Release());
    bind_combine<double, double>(m);
    bind_combine<float, double>(m);
    bind_combine<double, float>(m);
    bind_combine<float, float>(m);
    m.def("products_subtract_rows", &subtract_rows<double>, nb::arg("Q").noconvert(), nb::arg("rows"), nb::arg("X"),
          nb::arg("col"), Release(), "Q[rows[r]] -= X[r, col:col + Q.shape[1]].");
    m.def("products_subtract_rows", &subtract_rows<float>, nb::arg("Q").noconvert(), nb::arg("rows"), nb::arg("X"),
          nb::arg("col"), Release());
    bind_copy<double, double>(m);
    bind_copy<double, float>(m);
    bind_copy<float, double>(m);
    bind_copy<float, float>(m);
}

}  // namespace tmc
