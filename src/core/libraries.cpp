// The shared libraries the solver calls at run time, opened by path with dlopen:
//   * MKL's single runtime (libmkl_rt): PARDISO, the per-thread thread count, the BLAS the
//     fronts call, its buffer pool (solver/linalg/pardiso.py, multifrontal.py, service/state/memory.py);
//   * an OpenBLAS's own thread count (solver/linalg/threads.py);
//   * the objects loaded in the process, and glibc's heap settings (malloc_trim, mallopt).
// None of them is linked: MKL is optional, and numpy's, scipy's and the system's OpenBLAS are
// whichever the process loaded.
#include "common.h"

#include <nanobind/stl/string.h>
#include <nanobind/stl/tuple.h>
#include <nanobind/stl/vector.h>

#include <dlfcn.h>
#include <link.h>
#include <malloc.h>

#include <string>
#include <tuple>
#include <vector>

namespace tmc {

namespace {

// An array argument PARDISO reads or writes, any dtype: its data pointer, after checking that it
// is a contiguous CPU array of the item size PARDISO is told about.
using Raw = nb::ndarray<nb::device::cpu>;

// Raise Python's OSError (nanobind has no C++ exception type for it).
[[noreturn]] void os_error(const char *message) {
    PyErr_SetString(PyExc_OSError, message);
    throw nb::python_error();
}

void *data_of(const Raw &a, const char *what, size_t itemsize, size_t at_least) {
    bool contiguous = true;
    if (a.ndim() > 0) {  // C or Fortran order, as one block
        int64_t expect = 1;
        bool c = true, f = true;
        for (size_t k = a.ndim(); k-- > 0;) {
            if (a.shape(k) > 1 && a.stride(k) != expect) c = false;
            expect *= a.shape(k);
        }
        expect = 1;
        for (size_t k = 0; k < a.ndim(); ++k) {
            if (a.shape(k) > 1 && a.stride(k) != expect) f = false;
            expect *= a.shape(k);
        }
        contiguous = c || f;
    }
    if (!contiguous) throw nb::value_error((std::string(what) + ": not a contiguous array").c_str());
    if (a.itemsize() != itemsize)
        throw nb::value_error((std::string(what) + ": items of " + std::to_string(a.itemsize()) + " bytes, expected " +
                               std::to_string(itemsize)).c_str());
    if (a.size() < at_least)
        throw nb::value_error((std::string(what) + ": " + std::to_string(a.size()) + " items, expected at least " +
                               std::to_string(at_least)).c_str());
    return a.data();
}

void *open_library(const std::string &path, bool load) {
    void *h = dlopen(path.c_str(), RTLD_LAZY | RTLD_LOCAL | (load ? 0 : RTLD_NOLOAD));
    if (h == nullptr) {
        const char *why = dlerror();
        os_error((path + (load ? ": cannot be loaded (" : ": not loaded in this process (") +
                            (why ? why : "no reason given") + ")").c_str());
    }
    return h;
}

using PardisoFn = void (*)(void *, const int32_t *, const int32_t *, const int32_t *, const int32_t *,
                           const int32_t *, const void *, const int32_t *, const int32_t *, int32_t *,
                           const int32_t *, int32_t *, const int32_t *, void *, void *, int32_t *);
using LocalThreadsFn = int (*)(int);
using VoidFn = void (*)();
using GetThreadsFn = int (*)();
using SetThreadsFn = void (*)(int);

// MKL's runtime, opened once per object (dlopen counts references; the library stays loaded).
class Mkl {
  public:
    Mkl(const std::string &path, bool load) : path_(path), handle_(open_library(path, load)) {
        pardiso_ = reinterpret_cast<PardisoFn>(dlsym(handle_, "pardiso"));
        local_threads_ = reinterpret_cast<LocalThreadsFn>(dlsym(handle_, "MKL_Set_Num_Threads_Local"));
        free_buffers_ = reinterpret_cast<VoidFn>(dlsym(handle_, "mkl_free_buffers"));
        if (pardiso_ == nullptr) os_error((path + ": no pardiso entry point").c_str());
    }

    // One PARDISO call (MKL's argument order; 0-based or 1-based indices as iparm(35) says).
    // ``a``, ``b`` and ``x`` hold float64, or float32 when iparm(28) = 1. Returns PARDISO's error.
    int pardiso(Raw pt, int mtype, int phase, int n, Raw a, Raw ia, Raw ja, Raw perm, int nrhs, Raw iparm, Raw b,
                Raw x) const {
        void *pt_ = data_of(pt, "pt", 8, 64);
        int32_t *iparm_ = static_cast<int32_t *>(data_of(iparm, "iparm", 4, 64));
        size_t item = iparm_[27] == 1 ? 4 : 8;
        const int32_t *ia_ = static_cast<const int32_t *>(data_of(ia, "ia", 4, size_t(n) + 1));
        size_t nnz = phase < 0 ? 0 : size_t(ia_[n] - (iparm_[34] == 1 ? 0 : 1));
        const void *a_ = phase < 0 ? a.data() : data_of(a, "a", item, nnz);
        const int32_t *ja_ = static_cast<const int32_t *>(phase < 0 ? ja.data() : data_of(ja, "ja", 4, nnz));
        int32_t *perm_ = static_cast<int32_t *>(data_of(perm, "perm", 4, phase < 0 ? 0 : size_t(n)));
        size_t need = phase == 33 ? size_t(n) * size_t(nrhs) : 0;
        void *b_ = data_of(b, "b", item, need);
        void *x_ = data_of(x, "x", item, need);
        const int32_t one = 1, zero = 0;
        int32_t err = 0;
        {
            nb::gil_scoped_release released;
            pardiso_(pt_, &one, &one, &mtype, &phase, &n, a_, ia_, ja_, perm_, &nrhs, iparm_, &zero, b_, x_, &err);
        }
        return err;
    }

    // MKL's thread count for the calling thread only; returns the previous setting (0: the global one).
    int set_local_threads(int k) const { return local_threads_ ? local_threads_(k < 0 ? 0 : k) : 0; }

    void free_buffers() const {
        if (free_buffers_) free_buffers_();
    }

    // Addresses of dgemm, sgemm, dtrsm, strsm (Fortran interface), for multifrontal_use_blas.
    std::tuple<uintptr_t, uintptr_t, uintptr_t, uintptr_t> blas() const {
        auto at = [this](const char *name) {
            void *f = dlsym(handle_, name);
            if (f == nullptr) os_error((path_ + ": no " + name).c_str());
            return reinterpret_cast<uintptr_t>(f);
        };
        return {at("dgemm"), at("sgemm"), at("dtrsm"), at("strsm")};
    }

    const std::string &path() const { return path_; }

  private:
    std::string path_;
    void *handle_;
    PardisoFn pardiso_ = nullptr;
    LocalThreadsFn local_threads_ = nullptr;
    VoidFn free_buffers_ = nullptr;
};

// One loaded OpenBLAS's process-wide thread count, through its own functions (any thread may call them).
class OpenBLASThreads {
  public:
    explicit OpenBLASThreads(const std::string &path) : path_(path) {
        void *h = open_library(path, false);
        handle_ = h;
        // the plain names, and the affixes of numpy's and scipy's wheels (scipy-openblas32/64)
        for (const char *prefix : {"", "scipy_"}) {
            for (const char *suffix : {"", "64_", "_64"}) {
                std::string get = std::string(prefix) + "openblas_get_num_threads" + suffix;
                std::string set = std::string(prefix) + "openblas_set_num_threads" + suffix;
                void *g = dlsym(h, get.c_str()), *s = dlsym(h, set.c_str());
                if (g != nullptr && s != nullptr) {
                    get_ = reinterpret_cast<GetThreadsFn>(g);
                    set_ = reinterpret_cast<SetThreadsFn>(s);
                    return;
                }
            }
        }
        dlclose(h);
        os_error((path + ": no openblas_get_num_threads/openblas_set_num_threads").c_str());
    }

    OpenBLASThreads(const OpenBLASThreads &) = delete;
    OpenBLASThreads &operator=(const OpenBLASThreads &) = delete;
    ~OpenBLASThreads() { dlclose(handle_); }  // the reference this object took; its loader keeps the library

    int get() const { return get_(); }
    void set(int k) const { set_(k < 1 ? 1 : k); }
    const std::string &path() const { return path_; }

  private:
    std::string path_;
    void *handle_ = nullptr;
    GetThreadsFn get_ = nullptr;
    SetThreadsFn set_ = nullptr;
};

struct Loaded {
    unsigned long long adds = 0, subs = 0;
    std::vector<std::string> paths;
};

int visit(struct dl_phdr_info *info, size_t size, void *data) {
    auto *seen = static_cast<Loaded *>(data);
    if (size >= offsetof(struct dl_phdr_info, dlpi_subs) + sizeof(info->dlpi_subs)) {
        seen->adds = info->dlpi_adds;
        seen->subs = info->dlpi_subs;
    }
    if (info->dlpi_name != nullptr && info->dlpi_name[0] != '\0') seen->paths.emplace_back(info->dlpi_name);
    return 0;
}

int first_counts(struct dl_phdr_info *info, size_t size, void *data) {
    visit(info, size, data);
    return 1;  // the counts are the same in every entry: stop at the first
}

}  // namespace

void register_libraries(nb::module_ &m) {
    nb::class_<Mkl>(m, "Mkl", "MKL's single runtime library (libmkl_rt), opened by path.")
        .def(nb::init<const std::string &, bool>(), nb::arg("path"), nb::arg("load") = true,
             "Open it (``load=False``: only when the process has loaded it already; OSError otherwise).")
        .def("pardiso", &Mkl::pardiso, nb::arg("pt"), nb::arg("mtype"), nb::arg("phase"), nb::arg("n"), nb::arg("a"),
             nb::arg("ia"), nb::arg("ja"), nb::arg("perm").noconvert(), nb::arg("nrhs"), nb::arg("iparm").noconvert(),
             nb::arg("b"), nb::arg("x").noconvert(),
             "One PARDISO call without the GIL (maxfct = mnum = 1, msglvl = 0); returns its error code.")
        .def("set_local_threads", &Mkl::set_local_threads, nb::arg("k"),
             "MKL's threads for the calling thread (0: back to the global count); returns the previous setting.")
        .def("free_buffers", &Mkl::free_buffers, "Empty MKL's buffer pool (mkl_free_buffers).")
        .def("blas", &Mkl::blas, "Addresses of dgemm, sgemm, dtrsm and strsm.")
        .def_prop_ro("path", &Mkl::path);
    nb::class_<OpenBLASThreads>(m, "OpenBLASThreads", "A loaded OpenBLAS's thread count, through its own functions.")
        .def(nb::init<const std::string &>(), nb::arg("path"),
             "Find the functions in the library at ``path``, which must be loaded already (OSError otherwise).")
        .def("get_num_threads", &OpenBLASThreads::get, "The library's thread count (process-wide).")
        .def("set_num_threads", &OpenBLASThreads::set, nb::arg("k"), "Set it, from any thread.")
        .def_prop_ro("path", &OpenBLASThreads::path);
    m.def(
        "loaded_objects",
        []() {
            Loaded seen;
            dl_iterate_phdr(visit, &seen);
            return std::make_tuple(seen.adds, seen.subs, seen.paths);
        },
        "Shared objects loaded and unloaded so far (glibc's dlpi_adds, dlpi_subs) and the paths loaded now.");
    m.def(
        "load_counts",
        []() {
            Loaded seen;
            dl_iterate_phdr(first_counts, &seen);
            return std::make_tuple(seen.adds, seen.subs);
        },
        "Shared objects loaded and unloaded so far (glibc's dlpi_adds, dlpi_subs); cheaper than loaded_objects.");
    m.def(
        "trim_heap", []() { return malloc_trim(0) != 0; },
        "Return freed heap pages to the system (glibc's malloc_trim); True when some were.");
    m.def(
        "keep_freed_memory",
        []() {
            // glibc's M_MMAP_THRESHOLD and M_TRIM_THRESHOLD (solver/workflows/batch_memory.py says why)
            return mallopt(M_MMAP_THRESHOLD, 1 << 30) != 0 && mallopt(M_TRIM_THRESHOLD, 0x7fffffff) != 0;
        },
        "Raise glibc's mmap threshold to 1 GiB and its trim threshold to 2 GiB - 1; True when both were set.");
}

}  // namespace tmc
