// Shared by the kernel files of tetmorph_core: nanobind's array types and the OpenMP thread count.
#pragma once

#include <nanobind/nanobind.h>
#include <nanobind/ndarray.h>

#include <cstdint>

#ifdef _OPENMP
#include <omp.h>
#endif

namespace nb = nanobind;

namespace tmc {

// C-ordered arrays on the CPU. An argument the kernel writes into must be bound with
// nb::arg("name").noconvert(): otherwise nanobind may hand the kernel a converted copy and
// the writes would be lost.
template <class T>
using Vec = nb::ndarray<T, nb::ndim<1>, nb::c_contig, nb::device::cpu>;
template <class T>
using Mat = nb::ndarray<T, nb::ndim<2>, nb::c_contig, nb::device::cpu>;
template <class T>
using FMat = nb::ndarray<T, nb::ndim<2>, nb::f_contig, nb::device::cpu>;

// Every kernel runs without the GIL: solves run concurrently in threads.
using Release = nb::call_guard<nb::gil_scoped_release>;

// The threads an OpenMP loop started by the calling thread uses (set per calling thread by
// tetmorph_core.set_num_threads, as solver.linalg.threads does around a solve).
inline int num_threads() {
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 1;
#endif
}

// One registration function per kernel file (module.cpp calls each).
void register_threads(nb::module_ &m);
void register_multifrontal(nb::module_ &m);
void register_sweeps(nb::module_ &m);
void register_products(nb::module_ &m);
void register_geometry(nb::module_ &m);
void register_validity(nb::module_ &m);
void register_libraries(nb::module_ &m);

}  // namespace tmc
