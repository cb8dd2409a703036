// SUNDIALS' serial vector with its operations specialised to the state's fixed length.
#pragma once

#include <sundials/sundials_nvector.h>

namespace forklift {

// Replaces the arithmetic operations of `v`, a serial vector of StateIndex::kSize entries, with
// ones compiled for that length. Clones (the integrator's own vectors) inherit them. Each result
// is the same bits as the serial operation's: the same formula per case, sums in the same order.
void use_fixed_size_operations(N_Vector v);

}  // namespace forklift
