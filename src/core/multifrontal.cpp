// Multifrontal LU without pivoting (solver/linalg/multifrontal.py): the symbolic steps (elimination
// tree, postorder, column counts, relaxed supernodes, the supernodes' row sets) and the numeric
// factor of a postordered range of supernodes, whose dense fronts call BLAS (dtrsm, dgemm or their
// single-precision twins). Nothing links a BLAS at build time: the fronts call the one whose
// addresses multifrontal_use_blas gave (the Python caller hands over MKL's when it is installed), else
// SciPy's, whose addresses come from the capsules of scipy.linalg.cython_blas on first use.
#include "common.h"

#include <nanobind/stl/pair.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <utility>
#include <vector>

namespace tmc {
namespace {

using i64 = int64_t;

// ------------------------------------------------------------------------------------------- BLAS

// Fortran BLAS as scipy.linalg.cython_blas exports it: every argument by address, 32-bit ints.
using dgemm_t = void (*)(char *, char *, int *, int *, int *, double *, double *, int *, double *, int *,
                         double *, double *, int *);
using sgemm_t = void (*)(char *, char *, int *, int *, int *, float *, float *, int *, float *, int *, float *,
                         float *, int *);
using dtrsm_t = void (*)(char *, char *, char *, char *, int *, int *, double *, double *, int *, double *, int *);
using strsm_t = void (*)(char *, char *, char *, char *, int *, int *, float *, float *, int *, float *, int *);

struct Blas {
    dgemm_t dgemm;
    sgemm_t sgemm;
    dtrsm_t dtrsm;
    strsm_t strsm;
};

// SciPy's BLAS, looked up once (the first factor that uses it). The kernels run without the GIL;
// the lookup takes it for the import and the capsules. Any other thread that waits for this
// initialisation is inside a kernel too, so it does not hold the GIL.
const Blas &scipy_blas() {
    static const Blas table = [] {
        nb::gil_scoped_acquire gil;
        nb::object capi = nb::module_::import_("scipy.linalg.cython_blas").attr("__pyx_capi__");
        auto address = [&](const char *name) -> void * {
            nb::object cap = capi[name];
            void *p = PyCapsule_GetPointer(cap.ptr(), PyCapsule_GetName(cap.ptr()));
            if (p == nullptr)
                throw nb::python_error();
            return p;
        };
        Blas b;
        b.dgemm = reinterpret_cast<dgemm_t>(address("dgemm"));
        b.sgemm = reinterpret_cast<sgemm_t>(address("sgemm"));
        b.dtrsm = reinterpret_cast<dtrsm_t>(address("dtrsm"));
        b.strsm = reinterpret_cast<strsm_t>(address("strsm"));
        return b;
    }();
    return table;
}

// The BLAS that multifrontal_use_blas chose (MKL's, when installed), else SciPy's. A chosen table is
// never freed: a kernel may still be using the previous one.
std::atomic<const Blas *> chosen{nullptr};

const Blas &blas() {
    if (const Blas *b = chosen.load(std::memory_order_acquire))
        return *b;
    return scipy_blas();
}

inline void trsm(char side, char uplo, char transa, char diag, int m, int n, double alpha, double *a, int lda,
                 double *b, int ldb) {
    blas().dtrsm(&side, &uplo, &transa, &diag, &m, &n, &alpha, a, &lda, b, &ldb);
}
inline void trsm(char side, char uplo, char transa, char diag, int m, int n, float alpha, float *a, int lda,
                 float *b, int ldb) {
    blas().strsm(&side, &uplo, &transa, &diag, &m, &n, &alpha, a, &lda, b, &ldb);
}
inline void gemm(char ta, char tb, int m, int n, int k, double alpha, double *a, int lda, double *b, int ldb,
                 double beta, double *c, int ldc) {
    blas().dgemm(&ta, &tb, &m, &n, &k, &alpha, a, &lda, b, &ldb, &beta, c, &ldc);
}
inline void gemm(char ta, char tb, int m, int n, int k, float alpha, float *a, int lda, float *b, int ldb,
                 float beta, float *c, int ldc) {
    blas().sgemm(&ta, &tb, &m, &n, &k, &alpha, a, &lda, b, &ldb, &beta, c, &ldc);
}

// ------------------------------------------------------------------------------------------- symbolic

// Elimination tree of a symmetric pattern (CSC, both triangles): Liu's algorithm with path compression.
void etree(const i64 *Sp, const i64 *Si, i64 n, i64 *parent) {
    std::vector<i64> anc(n, -1);
    std::fill(parent, parent + n, -1);
    for (i64 j = 0; j < n; ++j)
        for (i64 p = Sp[j]; p < Sp[j + 1]; ++p) {
            i64 i = Si[p];
            while (i != -1 && i < j) {
                const i64 nxt = anc[i];
                anc[i] = j;
                if (nxt == -1)
                    parent[i] = j;
                i = nxt;
            }
        }
}

// A postorder of the forest `parent` (children in increasing order): post[k] is the k-th node.
void postorder(const i64 *parent, i64 n, i64 *post) {
    std::vector<i64> head(n, -1), nxt(n, -1), stack(n);
    for (i64 j = n - 1; j >= 0; --j) {  // child lists in increasing order
        const i64 p = parent[j];
        if (p >= 0) {
            nxt[j] = head[p];
            head[p] = j;
        }
    }
    i64 k = 0;
    for (i64 root = 0; root < n; ++root) {
        if (parent[root] != -1)
            continue;
        i64 top = 0;
        stack[0] = root;
        while (top >= 0) {
            const i64 v = stack[top];
            const i64 c = head[v];
            if (c == -1) {
                --top;
                post[k++] = v;
            } else {
                head[v] = nxt[c];
                stack[++top] = c;
            }
        }
    }
}

// Entries of every column of L (diagonal included), by the row subtrees of the elimination tree.
void column_counts(const i64 *Sp, const i64 *Si, const i64 *parent, i64 n, i64 *count) {
    std::fill(count, count + n, 1);
    std::vector<i64> mark(n, -1);
    for (i64 i = 0; i < n; ++i) {
        mark[i] = i;
        for (i64 p = Sp[i]; p < Sp[i + 1]; ++p) {
            i64 k = Si[p];
            if (k >= i)
                continue;
            while (mark[k] != i) {  // L[i, k] and the path up to the row subtree's visited part
                ++count[k];
                mark[k] = i;
                k = parent[k];
            }
        }
    }
}

// Which supernode starts survive relaxed merging: supernode s merges into s + 1 when that is its
// parent, not fixed, and the merged block's width and share of explicit zeros meet the first rule of
// `relax` (rows: most columns, most zeros) whose width it fits.
void amalgamate(const i64 *starts, i64 ns, const i64 *sparent, const i64 *count, const bool *fixed,
                const double *relax, i64 nrules, bool *keep) {
    std::fill(keep, keep + ns, true);
    if (ns == 0)
        return;
    i64 width = starts[1] - starts[0];
    i64 nz = width * (width + 1) / 2 + width * (count[starts[1] - 1] - 1);
    for (i64 s = 0; s < ns - 1; ++s) {
        const i64 w1 = starts[s + 2] - starts[s + 1];
        const i64 r1 = count[starts[s + 2] - 1] - 1;
        const i64 nz1 = w1 * (w1 + 1) / 2 + w1 * r1;
        bool merged = false;
        if (sparent[s] == s + 1 && !fixed[s + 1]) {
            const i64 w = width + w1;
            const i64 stored = w * (w + 1) / 2 + w * r1;
            const double zeros = 1.0 - static_cast<double>(nz + nz1) / static_cast<double>(stored);
            for (i64 k = 0; k < nrules; ++k)
                if (static_cast<double>(w) <= relax[2 * k]) {
                    merged = zeros <= relax[2 * k + 1];
                    break;
                }
        }
        if (merged) {
            keep[s + 1] = false;
            width += w1;
            nz += nz1;
        } else {
            width = w1;
            nz = nz1;
        }
    }
}

// Append row i to supernode s's rows at R[k] if it lies below the block and is new; -1 past `end`.
inline i64 take_row(i64 i, i64 c1, i64 s, i64 *mark, i64 *R, i64 k, i64 end) {
    if (i >= c1 && mark[i] != s) {
        if (k >= end)
            return -1;
        mark[i] = s;
        R[k++] = i;
    }
    return k;
}

// R of every supernode: rows of A below its columns and its children's R, beyond its last column,
// sorted. False when a count disagrees with the column counts behind rstart.
bool rows_below(const i64 *starts, i64 ns, const i64 *sparent, const i64 *Sp, const i64 *Si, i64 n,
                const i64 *rstart, i64 *R) {
    std::vector<i64> mark(n, -1), head(ns, -1), nxt(ns, -1);
    for (i64 s = ns - 1; s >= 0; --s) {
        const i64 p = sparent[s];
        if (p >= 0) {
            nxt[s] = head[p];
            head[p] = s;
        }
    }
    for (i64 s = 0; s < ns; ++s) {
        const i64 c0 = starts[s], c1 = starts[s + 1], end = rstart[s + 1];
        i64 k = rstart[s];
        for (i64 c = c0; c < c1; ++c)
            for (i64 p = Sp[c]; p < Sp[c + 1]; ++p) {
                k = take_row(Si[p], c1, s, mark.data(), R, k, end);
                if (k < 0)
                    return false;
            }
        for (i64 t = head[s]; t != -1; t = nxt[t])
            for (i64 q = rstart[t]; q < rstart[t + 1]; ++q) {
                k = take_row(R[q], c1, s, mark.data(), R, k, end);
                if (k < 0)
                    return false;
            }
        if (k != end)
            return false;
        std::sort(R + rstart[s], R + k);
    }
    return true;
}

// Most values the update-matrix stack holds while supernodes s_lo..s_hi-1 are factored, the update
// matrices of sizes `sizes0` on the stack before the first.
i64 stack_peak(i64 s_lo, i64 s_hi, const i64 *rstart, const i64 *nchild, const i64 *sizes0, i64 n0) {
    std::vector<i64> sizes(n0 + std::max<i64>(0, s_hi - s_lo));
    i64 top = n0, used = 0;
    for (i64 q = 0; q < n0; ++q) {
        sizes[q] = sizes0[q];
        used += sizes0[q];
    }
    i64 peak = used;
    for (i64 s = s_lo; s < s_hi; ++s) {
        for (i64 c = 0; c < nchild[s]; ++c)
            used -= sizes[--top];
        const i64 r = rstart[s + 1] - rstart[s];
        if (r) {
            sizes[top++] = r * r;
            used += r * r;
            peak = std::max(peak, used);
        }
    }
    return peak;
}

// ------------------------------------------------------------------------------------------- numeric

// LU of the first w pivots of the dense row-major (m, m) front F in place, in blocks of `panel`
// pivots; false on a zero or non-finite pivot. On return F[:w, :w] holds L11 (unit, strictly lower)
// and U11, F[w:, :w] L21, F[:w, w:] U12 and F[w:, w:] the Schur complement. BLAS sees the row-major
// front as its column-major transpose, so every call is written for the transposed blocks.
template <class T>
bool partial_lu(T *F, i64 m, i64 w, i64 panel) {
    const int ld = static_cast<int>(m);
    for (i64 k0 = 0; k0 < w; k0 += panel) {
        const i64 k1 = std::min(k0 + panel, w);
        const i64 b = k1 - k0;
        for (i64 k = k0; k < k1; ++k) {  // the diagonal block, unblocked
            const T piv = F[k * m + k];
            if (piv == T(0) || !std::isfinite(piv))
                return false;
            const double inv = 1.0 / static_cast<double>(piv);  // in double, as the reference kernel
            T *Fk = F + k * m;
            for (i64 i = k + 1; i < k1; ++i) {
                T *Fi = F + i * m;
                Fi[k] = static_cast<T>(static_cast<double>(Fi[k]) * inv);
                const T lik = Fi[k];
                if (lik != T(0))
                    for (i64 j = k + 1; j < k1; ++j)
                        Fi[j] -= lik * Fk[j];
            }
        }
        const i64 rest = m - k1;
        if (rest == 0)
            continue;
        const int nb = static_cast<int>(b), nr = static_cast<int>(rest);
        T *diag = F + k0 * m + k0;
        // L21 U11 = F21: in BLAS's view U11^T X = F21^T, U11^T the lower triangle of the block
        trsm('L', 'L', 'N', 'N', nb, nr, T(1), diag, ld, F + k1 * m + k0, ld);
        // L11 U12 = F12: in BLAS's view X L11^T = F12^T, L11^T the strict upper triangle, unit
        trsm('R', 'U', 'N', 'U', nr, nb, T(1), diag, ld, F + k0 * m + k1, ld);
        // F22 -= L21 U12: in BLAS's view F22^T -= U12^T L21^T
        gemm('N', 'N', nr, nr, nb, T(-1), F + k0 * m + k1, ld, F + k1 * m + k0, ld, T(1), F + k1 * m + k1, ld);
    }
    return true;
}

// Factor supernodes s_lo..s_hi-1 (a postordered range); returns (first bad supernode or -1, stack
// top). The update matrices waiting for their parent are a stack in buf: entry q < top is supernode
// ent_s[q]'s, r x r values from ent_off[q] over the rows R of that supernode. A supernode pops its
// children's (the last ones pushed, postorder) and pushes its own. Fbuf holds the largest front.
template <class T>
std::pair<i64, i64> factor_range(i64 s_lo, i64 s_hi, const i64 *starts, i64 n, const i64 *rstart, const i64 *R,
                                 const i64 *nchild, const i64 *Ap, const i64 *Ai, const T *Ax, const i64 *Tp,
                                 const i64 *Ti, const T *Tx, const i64 *bstart, const i64 *dstart, T *LB, T *UB,
                                 T *LD, T *UD, T *udinv, T *buf, i64 *ent_s, i64 *ent_off, i64 top, T *Fbuf,
                                 i64 panel) {
    std::vector<i64> loc(n, -1), cols;
    for (i64 s = s_lo; s < s_hi; ++s) {
        const i64 c0 = starts[s], c1 = starts[s + 1], w = c1 - c0;
        const i64 r0 = rstart[s], r = rstart[s + 1] - r0, m = w + r;
        for (i64 a = 0; a < w; ++a)
            loc[c0 + a] = a;
        for (i64 i = 0; i < r; ++i)
            loc[R[r0 + i]] = w + i;
        T *F = Fbuf;
        std::fill(F, F + m * m, T(0));
        for (i64 c = c0; c < c1; ++c) {  // columns of A: the diagonal block and L's part
            const i64 a = c - c0;
            for (i64 p = Ap[c]; p < Ap[c + 1]; ++p) {
                const i64 i = Ai[p];
                if (i >= c0)
                    F[loc[i] * m + a] += Ax[p];
            }
        }
        for (i64 c = c0; c < c1; ++c) {  // rows of A beyond the block: U's part
            T *Fa = F + (c - c0) * m;
            for (i64 p = Tp[c]; p < Tp[c + 1]; ++p) {
                const i64 j = Ti[p];
                if (j >= c1)
                    Fa[loc[j]] += Tx[p];
            }
        }
        for (i64 child = 0; child < nchild[s]; ++child) {  // extend-add of the children's update matrices
            --top;
            const i64 t = ent_s[top], off = ent_off[top];
            const i64 t0 = rstart[t], k = rstart[t + 1] - t0;
            cols.resize(k);
            for (i64 y = 0; y < k; ++y)
                cols[y] = loc[R[t0 + y]];
            const i64 *cy = cols.data();
            for (i64 x = 0; x < k; ++x) {
                T *Fx = F + cy[x] * m;
                const T *bx = buf + off + x * k;
                for (i64 y = 0; y < k; ++y)
                    Fx[cy[y]] += bx[y];
            }
        }
        if (!partial_lu(F, m, w, panel))
            return {s, top};
        const i64 d0 = dstart[s];
        for (i64 a = 0; a < w; ++a) {
            const T *Fa = F + a * m;
            udinv[c0 + a] = static_cast<T>(1.0 / static_cast<double>(Fa[a]));
            for (i64 e = 0; e < a; ++e)
                LD[d0 + a * w + e] = Fa[e];
            for (i64 e = a + 1; e < w; ++e)
                UD[d0 + a * w + e] = Fa[e];
        }
        const i64 b0 = bstart[s];
        for (i64 a = 0; a < w; ++a) {
            T *lb = LB + b0 + a * r;
            T *ub = UB + b0 + a * r;
            const T *Fa = F + a * m + w;
            for (i64 i = 0; i < r; ++i) {
                lb[i] = F[(w + i) * m + a];
                ub[i] = Fa[i];
            }
        }
        if (r) {
            i64 off = 0;
            if (top) {
                const i64 u = ent_s[top - 1], ku = rstart[u + 1] - rstart[u];
                off = ent_off[top - 1] + ku * ku;
            }
            for (i64 x = 0; x < r; ++x) {
                const T *Fx = F + (w + x) * m + w;
                T *bx = buf + off + x * r;
                for (i64 y = 0; y < r; ++y)
                    bx[y] = Fx[y];
            }
            ent_s[top] = s;
            ent_off[top] = off;
            ++top;
        }
        for (i64 a = 0; a < w; ++a)
            loc[c0 + a] = -1;
        for (i64 i = 0; i < r; ++i)
            loc[R[r0 + i]] = -1;
    }
    return {-1, top};
}

using IVec = Vec<const i64>;
using IOut = Vec<i64>;

template <class T>
void def_factor_range(nb::module_ &m) {
    m.def(
        "multifrontal_factor_range",
        [](i64 s_lo, i64 s_hi, IVec starts, IVec rstart, IVec R, IVec nchild, IVec Ap, IVec Ai, Vec<const T> Ax,
           IVec Tp, IVec Ti, Vec<const T> Tx, IVec bstart, IVec dstart, Vec<T> LB, Vec<T> UB, Vec<T> LD, Vec<T> UD,
           Vec<T> udinv, Vec<T> buf, IOut ent_s, IOut ent_off, i64 top, Vec<T> Fbuf, i64 panel) {
            const i64 n = starts.data()[starts.shape(0) - 1];
            return factor_range<T>(s_lo, s_hi, starts.data(), n, rstart.data(), R.data(), nchild.data(), Ap.data(),
                                   Ai.data(), Ax.data(), Tp.data(), Ti.data(), Tx.data(), bstart.data(),
                                   dstart.data(), LB.data(), UB.data(), LD.data(), UD.data(), udinv.data(),
                                   buf.data(), ent_s.data(), ent_off.data(), top, Fbuf.data(), panel);
        },
        nb::arg("s_lo"), nb::arg("s_hi"), nb::arg("starts"), nb::arg("rstart"), nb::arg("R"), nb::arg("nchild"),
        nb::arg("Ap"), nb::arg("Ai"), nb::arg("Ax"), nb::arg("Tp"), nb::arg("Ti"), nb::arg("Tx"), nb::arg("bstart"),
        nb::arg("dstart"), nb::arg("LB").noconvert(), nb::arg("UB").noconvert(), nb::arg("LD").noconvert(),
        nb::arg("UD").noconvert(), nb::arg("udinv").noconvert(), nb::arg("buf").noconvert(),
        nb::arg("ent_s").noconvert(), nb::arg("ent_off").noconvert(), nb::arg("top"), nb::arg("Fbuf").noconvert(),
        nb::arg("panel"), Release(),
        "Factor supernodes s_lo..s_hi-1 into the blocks LB, UB, LD, UD, udinv; returns (first bad supernode or "
        "-1, stack top).");
}

}  // namespace

void register_multifrontal(nb::module_ &m) {
    m.def(
        "multifrontal_etree",
        [](IVec Sp, IVec Si, IOut parent) { etree(Sp.data(), Si.data(), parent.shape(0), parent.data()); },
        nb::arg("Sp"), nb::arg("Si"), nb::arg("parent").noconvert(), Release(),
        "Elimination tree of a symmetric CSC pattern into parent (n,) (-1 for a root).");
    m.def(
        "multifrontal_postorder",
        [](IVec parent, IOut post) { postorder(parent.data(), post.shape(0), post.data()); },
        nb::arg("parent"), nb::arg("post").noconvert(), Release(),
        "A postorder of the forest parent (children in increasing order) into post (n,).");
    m.def(
        "multifrontal_column_counts",
        [](IVec Sp, IVec Si, IVec parent, IOut count) {
            column_counts(Sp.data(), Si.data(), parent.data(), count.shape(0), count.data());
        },
        nb::arg("Sp"), nb::arg("Si"), nb::arg("parent"), nb::arg("count").noconvert(), Release(),
        "Entries of every column of L (diagonal included) into count (n,).");
    m.def(
        "multifrontal_amalgamate",
        [](IVec starts, IVec sparent, IVec count, Vec<const bool> fixed, Mat<const double> relax,
           Vec<bool> keep) {
            amalgamate(starts.data(), keep.shape(0), sparent.data(), count.data(), fixed.data(), relax.data(),
                       relax.shape(0), keep.data());
        },
        nb::arg("starts"), nb::arg("sparent"), nb::arg("count"), nb::arg("fixed"), nb::arg("relax"),
        nb::arg("keep").noconvert(), Release(),
        "Which supernode starts survive relaxed merging, into keep (s,) bool.");
    m.def(
        "multifrontal_rows_below",
        [](IVec starts, IVec sparent, IVec Sp, IVec Si, IVec rstart, IOut R) {
            return rows_below(starts.data(), starts.shape(0) - 1, sparent.data(), Sp.data(), Si.data(),
                              Sp.shape(0) - 1, rstart.data(), R.data());
        },
        nb::arg("starts"), nb::arg("sparent"), nb::arg("Sp"), nb::arg("Si"), nb::arg("rstart"),
        nb::arg("R").noconvert(), Release(),
        "Every supernode's rows below its diagonal block into R; False when a count disagrees.");
    m.def(
        "multifrontal_stack_peak",
        [](i64 s_lo, i64 s_hi, IVec rstart, IVec nchild, IVec sizes0) {
            return stack_peak(s_lo, s_hi, rstart.data(), nchild.data(), sizes0.data(), sizes0.shape(0));
        },
        nb::arg("s_lo"), nb::arg("s_hi"), nb::arg("rstart"), nb::arg("nchild"), nb::arg("sizes0"), Release(),
        "Most values the update-matrix stack holds while s_lo..s_hi-1 are factored.");
    m.def(
        "multifrontal_use_blas",
        [](uintptr_t dgemm, uintptr_t sgemm, uintptr_t dtrsm, uintptr_t strsm) {
            if (!dgemm || !sgemm || !dtrsm || !strsm) {
                chosen.store(nullptr, std::memory_order_release);
                return;
            }
            chosen.store(new Blas{reinterpret_cast<dgemm_t>(dgemm), reinterpret_cast<sgemm_t>(sgemm),
                                  reinterpret_cast<dtrsm_t>(dtrsm), reinterpret_cast<strsm_t>(strsm)},
                         std::memory_order_release);
        },
        nb::arg("dgemm"), nb::arg("sgemm"), nb::arg("dtrsm"), nb::arg("strsm"), Release(),
        "Addresses of the Fortran BLAS (LP64: 32-bit ints) the fronts call from now on; any 0: SciPy's.");
    def_factor_range<double>(m);
    def_factor_range<float>(m);
}

}  // namespace tmc
