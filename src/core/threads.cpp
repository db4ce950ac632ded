// Thread count of the OpenMP loops, per calling thread (solver/linalg/threads.py).
#include "common.h"

namespace tmc {

void register_threads(nb::module_ &m) {
    m.def(
        "set_num_threads",
        [](int k) {
#ifdef _OPENMP
            omp_set_num_threads(k < 1 ? 1 : k);
#endif
        },
        nb::arg("k"), "Threads of the OpenMP loops the calling thread starts from now on.");
    m.def("get_num_threads", &num_threads, "Threads of the OpenMP loops the calling thread starts.");
    m.def(
        "max_threads",
        []() {
#ifdef _OPENMP
            return omp_get_num_procs();
#else
            return 1;
#endif
        },
        "Processors OpenMP sees (the most threads a loop is given).");
}

}  // namespace tmc
