// Kernels of solver/ (filled in file by file).
#include "common.h"

namespace tmc {

void register_geometry(nb::module_ &m) { (void)m; }

}  // namespace tmc
