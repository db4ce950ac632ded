// Geometry kernels of solver/ops/:
//   closest_point.py           geometry_closest_best, geometry_rays (point-triangle projection, ray casts)
//   mean_value_coordinates.py  geometry_mvc_weights (mean value weights of (point, triangle) pairs)
//   mvc_matrix.py              geometry_counting_sort, geometry_fill_rows, geometry_compact
//   rotation.py                geometry_rotate_by_log
//   displacement.py            geometry_max_disp
//   elements.py                geometry_corner_jacobians
#include "common.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace tmc {

template <class T, int D>
using CArr = nb::ndarray<T, nb::ndim<D>, nb::c_contig, nb::device::cpu>;

// The kernels below keep the operation order of the reference formulas and round every product
// and sum on its own: no fused multiply-adds (GCC contracts a * b + c by default where the
// target has FMA), so that the branch tests of the mean value coordinates (eps comparisons,
// coplanarity) decide as before.
#pragma GCC push_options
#pragma GCC optimize("fp-contract=off")

namespace {

// Python's max(a, b) / min(a, b): the first argument unless the second compares greater / smaller
// (so a NaN second argument is ignored, a NaN first argument kept).
inline double py_max(double a, double b) { return b > a ? b : a; }
inline double py_min(double a, double b) { return b < a ? b : a; }

constexpr double kPi = 3.141592653589793;

// ---------------------------------------------------------------- closest points (Ericson §5.1.5)

// Closest point of triangle (a, b, c) to p: barycentric (u, v, w) into out[0:3].
inline void closest_on_triangle(const double *p, const double *a, const double *b, const double *c,
                                double *out) {
    const double ab0 = b[0] - a[0], ab1 = b[1] - a[1], ab2 = b[2] - a[2];
    const double ac0 = c[0] - a[0], ac1 = c[1] - a[1], ac2 = c[2] - a[2];
    const double ap0 = p[0] - a[0], ap1 = p[1] - a[1], ap2 = p[2] - a[2];
    const double d1 = ab0 * ap0 + ab1 * ap1 + ab2 * ap2;
    const double d2 = ac0 * ap0 + ac1 * ap1 + ac2 * ap2;
    if (d1 <= 0.0 && d2 <= 0.0) {
        out[0] = 1.0, out[1] = 0.0, out[2] = 0.0;
        return;
    }
    const double bp0 = p[0] - b[0], bp1 = p[1] - b[1], bp2 = p[2] - b[2];
    const double d3 = ab0 * bp0 + ab1 * bp1 + ab2 * bp2;
    const double d4 = ac0 * bp0 + ac1 * bp1 + ac2 * bp2;
    if (d3 >= 0.0 && d4 <= d3) {
        out[0] = 0.0, out[1] = 1.0, out[2] = 0.0;
        return;
    }
    const double vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        const double v = d1 / (d1 - d3);
        out[0] = 1.0 - v, out[1] = v, out[2] = 0.0;
        return;
    }
    const double cp0 = p[0] - c[0], cp1 = p[1] - c[1], cp2 = p[2] - c[2];
    const double d5 = ab0 * cp0 + ab1 * cp1 + ab2 * cp2;
    const double d6 = ac0 * cp0 + ac1 * cp1 + ac2 * cp2;
    if (d6 >= 0.0 && d5 <= d6) {
        out[0] = 0.0, out[1] = 0.0, out[2] = 1.0;
        return;
    }
    const double vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        const double w = d2 / (d2 - d6);
        out[0] = 1.0 - w, out[1] = 0.0, out[2] = w;
        return;
    }
    const double va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
        const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        out[0] = 0.0, out[1] = 1.0 - w, out[2] = w;
        return;
    }
    const double denom = va + vb + vc;
    if (denom == 0.0) {  // degenerate triangle: its first vertex
        out[0] = 1.0, out[1] = 0.0, out[2] = 0.0;
        return;
    }
    const double v = vb / denom;
    const double w = vc / denom;
    out[0] = 1.0 - v - w, out[1] = v, out[2] = w;
}

// Per query point, the nearest projection on its candidate triangles (serial, like its caller expects).
void closest_best(const double *Q, int64_t q, const double *V, const int64_t *F, const int64_t *cand_ptr,
                  const int64_t *cand, int64_t *tri, double *bary, double *dist) {
    double out[3];
    for (int64_t i = 0; i < q; ++i) {
        const double *p = Q + 3 * i;
        double best = std::numeric_limits<double>::infinity();
        for (int64_t k = cand_ptr[i]; k < cand_ptr[i + 1]; ++k) {
            const int64_t t = cand[k];
            const double *a = V + 3 * F[3 * t], *b = V + 3 * F[3 * t + 1], *c = V + 3 * F[3 * t + 2];
            closest_on_triangle(p, a, b, c, out);
            double d = 0.0;
            for (int j = 0; j < 3; ++j) {
                const double x = out[0] * a[j] + out[1] * b[j] + out[2] * c[j] - p[j];
                d += x * x;
            }
            if (d < best) {
                best = d;
                tri[i] = t;
                bary[3 * i] = out[0], bary[3 * i + 1] = out[1], bary[3 * i + 2] = out[2];
            }
        }
        dist[i] = std::sqrt(best);
    }
}

// Per line X0 + s D, the candidate triangle it crosses with the smallest |s| (Möller-Trumbore).
void rays(const double *X0, int64_t q, const double *D, const double *V, const int64_t *F,
          const int64_t *cand_ptr, const int64_t *cand, int64_t *tri, double *bary, double *tpar) {
    for (int64_t i = 0; i < q; ++i) {
        const double *x = X0 + 3 * i, *dr = D + 3 * i;
        double best = std::numeric_limits<double>::infinity();
        tri[i] = -1;
        for (int64_t k = cand_ptr[i]; k < cand_ptr[i + 1]; ++k) {
            const int64_t t = cand[k];
            const double *a = V + 3 * F[3 * t], *b = V + 3 * F[3 * t + 1], *c = V + 3 * F[3 * t + 2];
            const double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
            const double e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
            const double pv[3] = {dr[1] * e2[2] - dr[2] * e2[1], dr[2] * e2[0] - dr[0] * e2[2],
                                  dr[0] * e2[1] - dr[1] * e2[0]};
            const double det = e1[0] * pv[0] + e1[1] * pv[1] + e1[2] * pv[2];
            if (std::abs(det) < 1e-300) continue;
            const double tv[3] = {x[0] - a[0], x[1] - a[1], x[2] - a[2]};
            const double u = (tv[0] * pv[0] + tv[1] * pv[1] + tv[2] * pv[2]) / det;
            if (u < -1e-12 || u > 1.0 + 1e-12) continue;
            const double qv[3] = {tv[1] * e1[2] - tv[2] * e1[1], tv[2] * e1[0] - tv[0] * e1[2],
                                  tv[0] * e1[1] - tv[1] * e1[0]};
            const double v = (dr[0] * qv[0] + dr[1] * qv[1] + dr[2] * qv[2]) / det;
            if (v < -1e-12 || u + v > 1.0 + 1e-12) continue;
            const double s = (e2[0] * qv[0] + e2[1] * qv[1] + e2[2] * qv[2]) / det;
            if (std::abs(s) < best) {
                best = std::abs(s);
                tri[i] = t;
                bary[3 * i] = 1.0 - u - v, bary[3 * i + 1] = u, bary[3 * i + 2] = v;
                tpar[i] = s;
            }
        }
    }
}

// ---------------------------------------------------------------- mean value coordinates

// Weights w (3,) that triangle (q0, q1, q2) gives its corners for point x: Ju, Schaefer & Warren
// 2005, Fig. 4 (theta_i = 2 asin(l_i / 2)), with the corner, near-face and coplanar cases;
// non-finite weights become 0. Returns whether x lies on the triangle (then w holds its
// barycentric weights, or the corner's indicator when x is at a corner).
inline bool mvc_pair(const double *x, const double *q0, const double *q1, const double *q2, double eps,
                     double *w) {
    double U[3][3], d[3], theta[3], sin_t[3], cc[3], ss[3];
    for (int j = 0; j < 3; ++j) {
        U[0][j] = q0[j] - x[j];
        U[1][j] = q1[j] - x[j];
        U[2][j] = q2[j] - x[j];
    }
    for (int c = 0; c < 3; ++c) d[c] = std::sqrt(U[c][0] * U[c][0] + U[c][1] * U[c][1] + U[c][2] * U[c][2]);
    const double tol = eps * py_max(py_max(d[0], d[1]), py_max(d[2], 1e-300));
    if (d[0] < tol || d[1] < tol || d[2] < tol) {  // at a corner: that corner alone
        for (int c = 0; c < 3; ++c) w[c] = d[c] < tol ? 1.0 : 0.0;
        return true;
    }
    for (int c = 0; c < 3; ++c)
        for (int j = 0; j < 3; ++j) U[c][j] /= d[c];
    for (int i = 0; i < 3; ++i) {  // l_i = |u_{i+1} - u_{i-1}|, theta_i = 2 asin(l_i / 2)
        const int a = (i + 1) % 3, b = (i + 2) % 3;
        const double e0 = U[a][0] - U[b][0], e1 = U[a][1] - U[b][1], e2 = U[a][2] - U[b][2];
        const double ell = std::sqrt(e0 * e0 + e1 * e1 + e2 * e2);
        theta[i] = 2.0 * std::asin(py_min(py_max(ell / 2.0, 0.0), 1.0));
        sin_t[i] = std::sin(theta[i]);
    }
    const double h = 0.5 * (theta[0] + theta[1] + theta[2]);
    if (kPi - h < eps) {  // on the triangle: 2D barycentric weights sin(theta_i) d_{i-1} d_{i+1}
        for (int i = 0; i < 3; ++i) w[i] = sin_t[i] * d[(i + 1) % 3] * d[(i + 2) % 3];
        return true;
    }
    const double det = (U[0][0] * (U[1][1] * U[2][2] - U[1][2] * U[2][1])
                        + U[0][1] * (U[1][2] * U[2][0] - U[1][0] * U[2][2])
                        + U[0][2] * (U[1][0] * U[2][1] - U[1][1] * U[2][0]));
    const double sgn = det > 0 ? 1.0 : (det < 0 ? -1.0 : 0.0);
    bool coplanar = false;
    const double sin_h = std::sin(h);
    for (int i = 0; i < 3; ++i) {
        double ci = 2.0 * sin_h * std::sin(h - theta[i]) / (sin_t[(i + 1) % 3] * sin_t[(i + 2) % 3]) - 1.0;
        if (std::isnan(ci) || ci > 1.0)
            ci = 1.0;
        else if (ci < -1.0)
            ci = -1.0;
        cc[i] = ci;
        ss[i] = sgn * std::sqrt(1.0 - ci * ci);
        if (std::abs(ss[i]) <= eps) coplanar = true;
    }
    for (int i = 0; i < 3; ++i) {  // x in the triangle's plane, outside it: no contribution
        const int a = (i + 1) % 3, b = (i + 2) % 3;
        double wi = 0.0;
        if (!coplanar) {
            wi = (theta[i] - cc[a] * theta[b] - cc[b] * theta[a]) / (d[i] * sin_t[a] * ss[b]);
            if (!std::isfinite(wi)) wi = 0.0;
        }
        w[i] = wi;
    }
    return false;
}

// Pair k: point x[k] (3,), triangle Q[k] (3, 3); weights into w[k], on-face flag into on_face[k].
void mvc_weights(const double *x, const double *Q, int64_t n, double eps, double *w, bool *on_face) {
#pragma omp parallel for schedule(static)
    for (int64_t k = 0; k < n; ++k) {
        const double *q = Q + 9 * k;
        on_face[k] = mvc_pair(x + 3 * k, q, q + 3, q + 6, eps, w + 3 * k);
    }
}

// ---------------------------------------------------------------- interior mean value matrix

// The flat indices p of flat (k,) with flat[p] >= 0, grouped by value (ptr (n + 1,) from their counts).
void counting_sort(const int64_t *flat, int64_t k, const int64_t *ptr, int64_t n, int64_t *out) {
    std::vector<int64_t> nxt(ptr, ptr + n);
    for (int64_t p = 0; p < k; ++p) {
        const int64_t v = flat[p];
        if (v >= 0) out[nxt[v]++] = p;
    }
}

struct Elements {
    const int64_t *E;     // (m, w) padded connectivity
    int64_t w;
    const int64_t *kind;  // (m,) type codes
    const int64_t *opp;   // (types, oc, ot, 3) opposite triangles, -1 padded
    int64_t oc, ot;
    const int64_t *ptr, *inc;  // incident (element, corner) pairs of each vertex
    const int64_t *tri(int64_t e, int64_t k) const { return opp + ((kind[e] * oc + k) * ot) * 3; }
};

// Sorted distinct vertices of the faces around i that do not contain it, into cols (nb: scratch).
inline void neighbours(const Elements &el, int64_t i, std::vector<int64_t> &nb, std::vector<int64_t> &cols) {
    nb.clear();
    for (int64_t a = el.ptr[i]; a < el.ptr[i + 1]; ++a) {
        const int64_t p = el.inc[a];
        const int64_t e = p / el.w, k = p % el.w;
        const int64_t *tri = el.tri(e, k);
        for (int64_t t = 0; t < el.ot; ++t) {
            if (tri[3 * t] < 0) break;
            for (int j = 0; j < 3; ++j) nb.push_back(el.E[e * el.w + tri[3 * t + j]]);
        }
    }
    std::sort(nb.begin(), nb.end());
    cols.assign(nb.begin(), std::unique(nb.begin(), nb.end()));
}

// Row r (vertex rows[r]): its neighbours into indices[slot[r]:] (count[r] of them), their normalised
// mean value weights into data, and the area of its local volume's boundary into S[rows[r]].
void fill_rows(const double *V, const Elements &el, const int64_t *rows, int64_t nrows, const int64_t *slot,
               int64_t *indices, double *data, int64_t *count, double *S, double eps) {
#pragma omp parallel
    {
        std::vector<int64_t> nb, cols;
        std::vector<double> acc;
        double w[3];
#pragma omp for schedule(dynamic, 64)
        for (int64_t r = 0; r < nrows; ++r) {
            const int64_t i = rows[r];
            neighbours(el, i, nb, cols);
            const int64_t nc = static_cast<int64_t>(cols.size());
            const int64_t lo = slot[r];
            count[r] = nc;
            acc.assign(nc, 0.0);
            double area = 0.0;
            bool special = false;
            const double *x = V + 3 * i;
            auto at = [&](int64_t v) { return std::lower_bound(cols.begin(), cols.end(), v) - cols.begin(); };
            for (int64_t a = el.ptr[i]; a < el.ptr[i + 1]; ++a) {
                const int64_t p = el.inc[a];
                const int64_t e = p / el.w, k = p % el.w;
                const int64_t *tri = el.tri(e, k);
                const int64_t *Ee = el.E + e * el.w;
                for (int64_t t = 0; t < el.ot; ++t) {
                    if (tri[3 * t] < 0) break;
                    const int64_t f0 = Ee[tri[3 * t]], f1 = Ee[tri[3 * t + 1]], f2 = Ee[tri[3 * t + 2]];
                    const double *p0 = V + 3 * f0, *p1 = V + 3 * f1, *p2 = V + 3 * f2;
                    const double ux = p1[0] - p0[0], uy = p1[1] - p0[1], uz = p1[2] - p0[2];
                    const double vx = p2[0] - p0[0], vy = p2[1] - p0[1], vz = p2[2] - p0[2];
                    const double cx = uy * vz - uz * vy, cy = uz * vx - ux * vz, cz = ux * vy - uy * vx;
                    area += 0.5 * std::sqrt(cx * cx + cy * cy + cz * cz);
                    if (special) continue;
                    if (mvc_pair(x, p0, p1, p2, eps, w)) {  // near-face case: this face's weights alone
                        std::fill(acc.begin(), acc.end(), 0.0);
                        special = true;
                    }
                    acc[at(f0)] += w[0];
                    acc[at(f1)] += w[1];
                    acc[at(f2)] += w[2];
                }
            }
            double tot = 0.0;
            for (int64_t c = 0; c < nc; ++c) tot += acc[c];
            for (int64_t c = 0; c < nc; ++c) {
                indices[lo + c] = cols[c];
                data[lo + c] = tot != 0.0 ? acc[c] / tot : 0.0;
            }
            S[i] = area;
        }
    }
}

// Row r's count[r] entries from slot[r] in (cols, vals) to indptr[rows[r]] in (indices, data).
void compact(const int64_t *rows, int64_t nrows, const int64_t *slot, const int64_t *cols, const double *vals,
             const int64_t *count, const int64_t *indptr, int64_t *indices, double *data) {
#pragma omp parallel for schedule(static)
    for (int64_t r = 0; r < nrows; ++r) {
        const int64_t a = slot[r], b = indptr[rows[r]];
        for (int64_t c = 0; c < count[r]; ++c) {
            indices[b + c] = cols[a + c];
            data[b + c] = vals[a + c];
        }
    }
}

// ---------------------------------------------------------------- rotations, displacements, elements

// out_i = f_i R(r_i) v_i by Rodrigues' formula, R(r) the rotation about r / |r| by 2 |r|.
void rotate_by_log(const double *v, const double *r, int64_t n, const double *scale, bool ones, double *out) {
#pragma omp parallel for schedule(static)
    for (int64_t i = 0; i < n; ++i) {
        const double f = ones ? 1.0 : scale[i];
        const double *ri = r + 3 * i, *vi = v + 3 * i;
        double *o = out + 3 * i;
        const double half = std::sqrt(ri[0] * ri[0] + ri[1] * ri[1] + ri[2] * ri[2]);
        if (half == 0.0) {
            o[0] = f * vi[0], o[1] = f * vi[1], o[2] = f * vi[2];
            continue;
        }
        const double ax = ri[0] / half, ay = ri[1] / half, az = ri[2] / half;
        const double c = std::cos(2.0 * half), s = std::sin(2.0 * half);
        const double vx = vi[0], vy = vi[1], vz = vi[2];
        const double k = (ax * vx + ay * vy + az * vz) * (1.0 - c);
        o[0] = f * (vx * c + (ay * vz - az * vy) * s + ax * k);
        o[1] = f * (vy * c + (az * vx - ax * vz) * s + ay * k);
        o[2] = f * (vz * c + (ax * vy - ay * vx) * s + az * k);
    }
}

// Chunk c of nch (rows c n / nch to (c + 1) n / nch): the largest squared displacement per role
// (0 free, 1 handle, 2 fixed; all free when owner is not (n,)) into best[c], non-finite rows into bad[c].
void max_disp(const double *P, const double *V, int64_t n, const int64_t *owner, int64_t n_owner, int64_t nch,
              double *best, int64_t *bad) {
    const bool roles = n_owner == n;
#pragma omp parallel for schedule(static)
    for (int64_t c = 0; c < nch; ++c) {
        double m2[3] = {0.0, 0.0, 0.0};
        int64_t nonfinite = 0;
        for (int64_t i = c * n / nch; i < (c + 1) * n / nch; ++i) {
            const double x = P[3 * i], y = P[3 * i + 1], z = P[3 * i + 2];
            nonfinite += !(std::isfinite(x) && std::isfinite(y) && std::isfinite(z));
            const double dx = x - V[3 * i], dy = y - V[3 * i + 1], dz = z - V[3 * i + 2];
            int g = 0;
            if (roles) {
                const int64_t o = owner[i];
                g = o >= 0 ? 1 : (o == -2 ? 2 : 0);
            }
            m2[g] = py_max(m2[g], dx * dx + dy * dy + dz * dz);
        }
        for (int g = 0; g < 3; ++g) best[3 * c + g] = m2[g];
        bad[c] = nonfinite;
    }
}

// Element e (m, ne nodes): the smallest corner Jacobian det(e1, e2, e3) over the corner tets C (nc, 4)
// into det[e], the smallest scaled one, clamped to [-1, 1], into sj[e].
void corner_jacobians(const double *V, const int64_t *E, int64_t m, int64_t ne, const int64_t *C, int64_t nc,
                      double scale, double *det, double *sj) {
#pragma omp parallel for schedule(static)
    for (int64_t e = 0; e < m; ++e) {
        const int64_t *Ee = E + e * ne;
        for (int64_t k = 0; k < nc; ++k) {
            const double *A = V + 3 * Ee[C[4 * k]], *B = V + 3 * Ee[C[4 * k + 1]];
            const double *Cc = V + 3 * Ee[C[4 * k + 2]], *D = V + 3 * Ee[C[4 * k + 3]];
            const double ux = B[0] - A[0], uy = B[1] - A[1], uz = B[2] - A[2];
            const double vx = Cc[0] - A[0], vy = Cc[1] - A[1], vz = Cc[2] - A[2];
            const double wx = D[0] - A[0], wy = D[1] - A[1], wz = D[2] - A[2];
            const double j = ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx);
            const double ll = std::sqrt((ux * ux + uy * uy + uz * uz) * (vx * vx + vy * vy + vz * vz)
                                        * (wx * wx + wy * wy + wz * wz));
            const double s = j == 0.0 ? 0.0 : py_min(1.0, py_max(-1.0, scale * j / ll));
            if (k == 0 || j < det[e]) det[e] = j;
            if (k == 0 || s < sj[e]) sj[e] = s;
        }
    }
}

}  // namespace

#pragma GCC pop_options

namespace {

template <class T>
using In1 = CArr<const T, 1>;
template <class T>
using In2 = CArr<const T, 2>;

void require(bool ok, const char *what) {
    if (!ok) throw nb::value_error(what);
}

}  // namespace

void register_geometry(nb::module_ &m) {
    m.def(
        "geometry_closest_best",
        [](In2<double> Q, In2<double> V, In2<int64_t> F, In1<int64_t> cand_ptr, In1<int64_t> cand,
           CArr<int64_t, 1> tri, CArr<double, 2> bary, CArr<double, 1> dist) {
            const size_t q = Q.shape(0);
            require(Q.shape(1) == 3 && V.shape(1) == 3 && F.shape(1) == 3 && bary.shape(1) == 3,
                    "geometry_closest_best: Q, V, F and bary need 3 columns");
            require(cand_ptr.shape(0) == q + 1, "geometry_closest_best: cand_ptr needs q + 1 entries");
            require(tri.shape(0) == q && bary.shape(0) == q && dist.shape(0) == q,
                    "geometry_closest_best: tri, bary and dist need q rows");
            closest_best(Q.data(), static_cast<int64_t>(q), V.data(), F.data(), cand_ptr.data(), cand.data(),
                         tri.data(), bary.data(), dist.data());
        },
        nb::arg("Q"), nb::arg("V"), nb::arg("F"), nb::arg("cand_ptr"), nb::arg("cand"),
        nb::arg("tri").noconvert(), nb::arg("bary").noconvert(), nb::arg("dist").noconvert(), Release(),
        "Nearest projection of each point Q[i] on its candidate triangles cand[cand_ptr[i]:cand_ptr[i + 1]]:\n"
        "triangle into tri, barycentric coordinates into bary, distance into dist (inf without candidates).");
    m.def(
        "geometry_rays",
        [](In2<double> X0, In2<double> D, In2<double> V, In2<int64_t> F, In1<int64_t> cand_ptr,
           In1<int64_t> cand, CArr<int64_t, 1> tri, CArr<double, 2> bary, CArr<double, 1> tpar) {
            const size_t q = X0.shape(0);
            require(X0.shape(1) == 3 && D.shape(1) == 3 && V.shape(1) == 3 && F.shape(1) == 3 && bary.shape(1) == 3,
                    "geometry_rays: X0, D, V, F and bary need 3 columns");
            require(cand_ptr.shape(0) == q + 1, "geometry_rays: cand_ptr needs q + 1 entries");
            require(D.shape(0) == q && tri.shape(0) == q && bary.shape(0) == q && tpar.shape(0) == q,
                    "geometry_rays: D, tri, bary and tpar need q rows");
            rays(X0.data(), static_cast<int64_t>(q), D.data(), V.data(), F.data(), cand_ptr.data(), cand.data(),
                 tri.data(), bary.data(), tpar.data());
        },
        nb::arg("X0"), nb::arg("D"), nb::arg("V"), nb::arg("F"), nb::arg("cand_ptr"), nb::arg("cand"),
        nb::arg("tri").noconvert(), nb::arg("bary").noconvert(), nb::arg("tpar").noconvert(), Release(),
        "Per line X0[i] + s D[i], the candidate triangle crossed with the smallest |s|: triangle into tri\n"
        "(-1: none), barycentric coordinates into bary, s into tpar.");
    m.def(
        "geometry_mvc_weights",
        [](In2<double> x, CArr<const double, 3> Q, double eps, CArr<double, 2> w, CArr<bool, 1> on_face) {
            const size_t n = x.shape(0);
            require(x.shape(1) == 3 && Q.shape(1) == 3 && Q.shape(2) == 3 && w.shape(1) == 3,
                    "geometry_mvc_weights: x (N, 3), Q (N, 3, 3), w (N, 3)");
            require(Q.shape(0) == n && w.shape(0) == n && on_face.shape(0) == n,
                    "geometry_mvc_weights: x, Q, w and on_face need N rows");
            mvc_weights(x.data(), Q.data(), static_cast<int64_t>(n), eps, w.data(), on_face.data());
        },
        nb::arg("x"), nb::arg("Q"), nb::arg("eps"), nb::arg("w").noconvert(), nb::arg("on_face").noconvert(),
        Release(),
        "Mean value weights (Ju et al. 2005, Fig. 4) that triangle Q[k] (3, 3) gives its corners for point\n"
        "x[k] into w[k]; whether x[k] lies on the triangle into on_face[k].");
    m.def(
        "geometry_counting_sort",
        [](In1<int64_t> flat, In1<int64_t> ptr, CArr<int64_t, 1> out) {
            require(ptr.shape(0) >= 1, "geometry_counting_sort: ptr needs n + 1 entries");
            const size_t n = ptr.shape(0) - 1;
            require(out.shape(0) == static_cast<size_t>(ptr.data()[n]), "geometry_counting_sort: out needs ptr[-1]");
            counting_sort(flat.data(), static_cast<int64_t>(flat.shape(0)), ptr.data(), static_cast<int64_t>(n),
                          out.data());
        },
        nb::arg("flat"), nb::arg("ptr"), nb::arg("out").noconvert(), Release(),
        "Indices p with flat[p] >= 0 grouped by flat[p], in order, into out (ptr: the groups' offsets).");
    m.def(
        "geometry_fill_rows",
        [](In2<double> V, In2<int64_t> E, In1<int64_t> kind, CArr<const int64_t, 4> opp, In1<int64_t> ptr,
           In1<int64_t> inc, In1<int64_t> rows, In1<int64_t> slot, CArr<int64_t, 1> indices,
           CArr<double, 1> data, CArr<int64_t, 1> count, CArr<double, 1> S, double eps) {
            const size_t nr = rows.shape(0);
            require(V.shape(1) == 3 && opp.shape(3) == 3, "geometry_fill_rows: V (n, 3), opp (t, c, k, 3)");
            require(slot.shape(0) == nr + 1 && count.shape(0) == nr && S.shape(0) == V.shape(0)
                        && ptr.shape(0) == V.shape(0) + 1 && kind.shape(0) == E.shape(0),
                    "geometry_fill_rows: slot (r + 1,), count (r,), S (n,), ptr (n + 1,), kind (m,)");
            require(indices.shape(0) == data.shape(0) && indices.shape(0) >= static_cast<size_t>(slot.data()[nr]),
                    "geometry_fill_rows: indices and data need slot[-1] entries");
            Elements el{E.data(), static_cast<int64_t>(E.shape(1)), kind.data(), opp.data(),
                        static_cast<int64_t>(opp.shape(1)), static_cast<int64_t>(opp.shape(2)), ptr.data(), inc.data()};
            fill_rows(V.data(), el, rows.data(), static_cast<int64_t>(nr), slot.data(), indices.data(), data.data(),
                      count.data(), S.data(), eps);
        },
        nb::arg("V"), nb::arg("E"), nb::arg("kind"), nb::arg("opp"), nb::arg("ptr"), nb::arg("inc"), nb::arg("rows"),
        nb::arg("slot"), nb::arg("indices").noconvert(), nb::arg("data").noconvert(), nb::arg("count").noconvert(),
        nb::arg("S").noconvert(), nb::arg("eps"), Release(),
        "Mean value rows of the vertices rows (one parallel pass): row r's neighbours and normalised weights\n"
        "into indices / data from slot[r], their number into count[r], its local volume's boundary area into S.");
    m.def(
        "geometry_compact",
        [](In1<int64_t> rows, In1<int64_t> slot, In1<int64_t> cols, In1<double> vals, In1<int64_t> count,
           In1<int64_t> indptr, CArr<int64_t, 1> indices, CArr<double, 1> data) {
            const size_t nr = rows.shape(0);
            require(slot.shape(0) >= nr && count.shape(0) == nr && cols.shape(0) == vals.shape(0)
                        && indices.shape(0) == data.shape(0) && indptr.shape(0) >= 1
                        && indices.shape(0) == static_cast<size_t>(indptr.data()[indptr.shape(0) - 1]),
                    "geometry_compact: slot (r + 1,), count (r,), cols and vals alike, indices and data (indptr[-1],)");
            compact(rows.data(), static_cast<int64_t>(nr), slot.data(), cols.data(), vals.data(), count.data(),
                    indptr.data(), indices.data(), data.data());
        },
        nb::arg("rows"), nb::arg("slot"), nb::arg("cols"), nb::arg("vals"), nb::arg("count"), nb::arg("indptr"),
        nb::arg("indices").noconvert(), nb::arg("data").noconvert(), Release(),
        "Row r's count[r] entries from slot[r] of (cols, vals) to indptr[rows[r]] of (indices, data).");
    m.def(
        "geometry_rotate_by_log",
        [](In2<double> v, In2<double> r, In1<double> scale, bool ones, CArr<double, 2> out) {
            const size_t n = v.shape(0);
            require(v.shape(1) == 3 && r.shape(1) == 3 && out.shape(1) == 3 && r.shape(0) == n && out.shape(0) == n
                        && (ones || scale.shape(0) == n),
                    "geometry_rotate_by_log: v, r, out (k, 3), scale (k,)");
            rotate_by_log(v.data(), r.data(), static_cast<int64_t>(n), scale.data(), ones, out.data());
        },
        nb::arg("v"), nb::arg("r"), nb::arg("scale"), nb::arg("ones"), nb::arg("out").noconvert(), Release(),
        "out[i] = scale[i] R(r[i]) v[i] (scale ignored when ones), R(r) about r / |r| by 2 |r|.");
    m.def(
        "geometry_max_disp",
        [](In2<double> P, In2<double> V, In1<int64_t> owner, int64_t nch, CArr<double, 2> best,
           CArr<int64_t, 1> bad) {
            const size_t n = P.shape(0);
            require(P.shape(1) == 3 && V.shape(1) == 3 && V.shape(0) == n && nch >= 1 && best.shape(1) == 3
                        && best.shape(0) == static_cast<size_t>(nch) && bad.shape(0) == static_cast<size_t>(nch),
                    "geometry_max_disp: P, V (n, 3), best (nch, 3), bad (nch,)");
            max_disp(P.data(), V.data(), static_cast<int64_t>(n), owner.data(), static_cast<int64_t>(owner.shape(0)),
                     nch, best.data(), bad.data());
        },
        nb::arg("P"), nb::arg("V"), nb::arg("owner"), nb::arg("nch"), nb::arg("best").noconvert(),
        nb::arg("bad").noconvert(), Release(),
        "Per chunk c of nch: largest squared |P_i - V_i| of free, handle and fixed nodes (owner -1, >= 0, -2;\n"
        "all free when owner is not (n,)) into best[c], the number of non-finite rows of P into bad[c].");
    m.def(
        "geometry_corner_jacobians",
        [](In2<double> V, In2<int64_t> E, In2<int64_t> C, double scale, CArr<double, 1> det, CArr<double, 1> sj) {
            const size_t m_ = E.shape(0);
            require(V.shape(1) == 3 && C.shape(1) == 4 && det.shape(0) == m_ && sj.shape(0) == m_,
                    "geometry_corner_jacobians: V (n, 3), C (c, 4), det and sj (m,)");
            corner_jacobians(V.data(), E.data(), static_cast<int64_t>(m_), static_cast<int64_t>(E.shape(1)),
                             C.data(), static_cast<int64_t>(C.shape(0)), scale, det.data(), sj.data());
        },
        nb::arg("V"), nb::arg("E"), nb::arg("C"), nb::arg("scale"), nb::arg("det").noconvert(),
        nb::arg("sj").noconvert(), Release(),
        "Smallest corner Jacobian of each element E[e] over its corner tets C into det[e], smallest scaled\n"
        "Jacobian (times scale, clamped to [-1, 1]) into sj[e].");
}

}  // namespace tmc
