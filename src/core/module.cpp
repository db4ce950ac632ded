// tetmorph_core: the compiled kernels behind solver/ (see each file's header for its Python caller).
#include "common.h"

NB_MODULE(tetmorph_core, m) {
    m.doc() = "tetmorph's compiled kernels (C++17, OpenMP); called from solver/, not a public API";
    tmc::register_threads(m);
    tmc::register_multifrontal(m);
    tmc::register_sweeps(m);
    tmc::register_products(m);
    tmc::register_geometry(m);
    tmc::register_validity(m);
    tmc::register_libraries(m);
}
