// Kernels of solver/ (filled in file by file).
#include "common.h"

namespace tmc {

void register_validity(nb::module_ &m) { (void)m; }

}  // namespace tmc
