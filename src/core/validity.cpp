// Kernels of solver/validity/check.py (the per-update tet check: scaled Jacobians, the tally of
// bad tets, the values around the 1st percentile) and solver/validity/quality.py (tet_quality).
#include "common.h"

#include <cmath>

namespace tmc {
namespace {

template <class T>
using CVec = Vec<const T>;
template <class T>
using CMat = Mat<const T>;

// a * b + c with one rounding where the machine has fused multiply-adds. Written out, so that the
// check kernel and tet_quality round alike whatever the compiler's contraction does (and as the
// former kernels did: a * b - c * d is fma(a, b, -(c * d)), a * b + c * d is fma(a, b, c * d)).
inline double mul_add(double a, double b, double c) {
#ifdef __FMA__
    return __builtin_fma(a, b, c);
#else
    return a * b + c;
#endif
}

// Python's max(a, b) and min(a, b) of floats: the first argument unless the second compares
// greater (smaller), so max(-1.0, nan) is -1.0.
inline double py_max(double a, double b) { return b > a ? b : a; }
inline double py_min(double a, double b) { return b < a ? b : a; }

// Six times the signed volume and the scaled Jacobian of the tet with edges u, v, w from one corner:
// sj = sqrt(2) det / sqrt(max over corners of the product of its three squared edge lengths),
// clipped to [-1, 1]; 0 for a flat tet. No branch on the data, so that a loop of it vectorizes.
inline void edge_det_sj(double ux, double uy, double uz, double vx, double vy, double vz, double wx, double wy,
                        double wz, double &det_out, double &sj_out) {
    const double c1 = mul_add(vy, wz, -(vz * wy));
    const double c2 = mul_add(vz, wx, -(vx * wz));
    const double c3 = mul_add(vx, wy, -(vy * wx));
    const double det = mul_add(uz, c3, mul_add(ux, c1, uy * c2));
    const double l01 = mul_add(uz, uz, mul_add(ux, ux, uy * uy));
    const double l02 = mul_add(vz, vz, mul_add(vx, vx, vy * vy));
    const double l03 = mul_add(wz, wz, mul_add(wx, wx, wy * wy));
    const double ax = vx - ux, ay = vy - uy, az = vz - uz;
    const double bx = wx - ux, by = wy - uy, bz = wz - uz;
    const double cx = wx - vx, cy = wy - vy, cz = wz - vz;
    const double l12 = mul_add(az, az, mul_add(ax, ax, ay * ay));
    const double l13 = mul_add(bz, bz, mul_add(bx, bx, by * by));
    const double l23 = mul_add(cz, cz, mul_add(cx, cx, cy * cy));
    const double corner = py_max(py_max(l01 * l02 * l03, l01 * l12 * l13), py_max(l02 * l12 * l23, l03 * l13 * l23));
    const double s = py_min(1.0, py_max(-1.0, 1.4142135623730951 * det / std::sqrt(corner)));
    det_out = det;
    sj_out = det != 0.0 ? s : 0.0;
}

// Scaled Jacobian of every tet: F the (3 n,) flat coordinates, TC the (4, m) corner rows.
template <class I>
void sj_kernel(CVec<double> F, CMat<I> TC, Vec<double> sj) {
    const int64_t m = TC.shape(1);
    const double *f = F.data();
    const I *A = TC.data(), *B = A + m, *C = B + m, *D = C + m;
    double *out = sj.data();
#pragma omp parallel for simd schedule(static)
    for (int64_t t = 0; t < m; ++t) {
        const int64_t a = 3 * int64_t(A[t]), b = 3 * int64_t(B[t]), c = 3 * int64_t(C[t]), d = 3 * int64_t(D[t]);
        const double x0 = f[a], y0 = f[a + 1], z0 = f[a + 2];
        double det, s;
        edge_det_sj(f[b] - x0, f[b + 1] - y0, f[b + 2] - z0, f[c] - x0, f[c + 1] - y0, f[c + 2] - z0, f[d] - x0,
                    f[d + 1] - y0, f[d + 2] - z0, det, s);
        out[t] = s;
    }
}

// Per chunk: counts[c] = (bad, degenerate, below lo_v, in [lo_v, hi_v]) and the first bad positions.
// Bad: sj <= tol, and, for a tet flat at rest, sj < -tol; NaN is never bad.
void tally_kernel(CVec<double> sj, double tol, CVec<uint8_t> flat, double lo_v, double hi_v, Mat<int64_t> counts,
                  Mat<int64_t> first) {
    const int64_t m = sj.shape(0), nch = counts.shape(0), cap = first.shape(1);
    const double *s_ = sj.data();
    const uint8_t *fl = flat.data();
    int64_t *cnt = counts.data(), *fst = first.data();
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        const int64_t lo = c * m / nch, hi = (c + 1) * m / nch;
        int64_t nbad = 0, ndeg = 0, below = 0, inside = 0;
#pragma omp simd reduction(+ : nbad, ndeg, below, inside)
        for (int64_t t = lo; t < hi; ++t) {
            const double s = s_[t];
            ndeg += std::fabs(s) <= tol;
            nbad += (s <= tol) & ((fl[t] == 0) | (s < -tol));
            below += s < lo_v;
            inside += (s >= lo_v) & (s <= hi_v);
        }
        if (nbad) {
            int64_t n = 0;
            for (int64_t t = lo; t < hi; ++t) {
                const double s = s_[t];
                if ((s <= tol) & ((fl[t] == 0) | (s < -tol))) {
                    fst[c * cap + n] = t;
                    if (++n == cap) break;
                }
            }
        }
        cnt[4 * c] = nbad;
        cnt[4 * c + 1] = ndeg;
        cnt[4 * c + 2] = below;
        cnt[4 * c + 3] = inside;
    }
}

// The values of sj in [lo_v, hi_v], chunk c's from out[start[c]] on.
void gather_between(CVec<double> sj, double lo_v, double hi_v, CVec<int64_t> start, Vec<double> out) {
    const int64_t m = sj.shape(0), nch = start.shape(0);
    const double *s_ = sj.data();
    const int64_t *st = start.data();
    double *o = out.data();
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        int64_t n = st[c];
        for (int64_t t = c * m / nch; t < (c + 1) * m / nch; ++t) {
            const double s = s_[t];
            if (s >= lo_v && s <= hi_v) o[n++] = s;
        }
    }
}

// Six times the signed volume and the scaled Jacobian of every tet of T, (m, 4), at V, (n, 3).
template <class I>
void tet_quality_kernel(CMat<double> V, CMat<I> T, Vec<double> vol6, Vec<double> sj) {
    const int64_t m = T.shape(0);
    const double *v = V.data();
    const I *tt = T.data();
    double *o6 = vol6.data(), *os = sj.data();
#pragma omp parallel for simd schedule(static)
    for (int64_t t = 0; t < m; ++t) {
        const int64_t a = 3 * int64_t(tt[4 * t]), b = 3 * int64_t(tt[4 * t + 1]), c = 3 * int64_t(tt[4 * t + 2]),
                      d = 3 * int64_t(tt[4 * t + 3]);
        const double x0 = v[a], y0 = v[a + 1], z0 = v[a + 2];
        double det, s;
        edge_det_sj(v[b] - x0, v[b + 1] - y0, v[b + 2] - z0, v[c] - x0, v[c + 1] - y0, v[c + 2] - z0, v[d] - x0,
                    v[d + 1] - y0, v[d + 2] - z0, det, s);
        o6[t] = det;
        os[t] = s;
    }
}

}  // namespace

void register_validity(nb::module_ &m) {
    m.def("validity_sj", &sj_kernel<int32_t>, nb::arg("F"), nb::arg("TC"), nb::arg("sj").noconvert(), Release(),
          "Scaled Jacobian of every tet into sj, (m,): F (3 n,) flat coordinates, TC (4, m) corner rows.");
    m.def("validity_sj", &sj_kernel<int64_t>, nb::arg("F"), nb::arg("TC"), nb::arg("sj").noconvert(), Release());
    m.def("validity_tally", &tally_kernel, nb::arg("sj"), nb::arg("tol"), nb::arg("flat"), nb::arg("lo_v"),
          nb::arg("hi_v"), nb::arg("counts").noconvert(), nb::arg("first").noconvert(), Release(),
          "Per chunk of sj: (bad, degenerate, below lo_v, in [lo_v, hi_v]) into counts, (nch, 4), and the "
          "first bad positions into first, (nch, cap).");
    m.def("validity_gather_between", &gather_between, nb::arg("sj"), nb::arg("lo_v"), nb::arg("hi_v"),
          nb::arg("start"), nb::arg("out").noconvert(), Release(),
          "The values of sj in [lo_v, hi_v] into out, chunk c's (of start.size equal chunks) from start[c] on.");
    m.def("validity_tet_quality", &tet_quality_kernel<int32_t>, nb::arg("V"), nb::arg("T"),
          nb::arg("vol6").noconvert(), nb::arg("sj").noconvert(), Release(),
          "Six times the signed volume and the scaled Jacobian of every tet of T, (m, 4), at V, (n, 3).");
    m.def("validity_tet_quality", &tet_quality_kernel<int64_t>, nb::arg("V"), nb::arg("T"),
          nb::arg("vol6").noconvert(), nb::arg("sj").noconvert(), Release());
}

}  // namespace tmc
