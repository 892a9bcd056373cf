#pragma once
// Parameters of the self-test kernel (kernels/selftest.cl); the host checks this layout at compile
// time (src/brdf/cl/self_test.cpp) and the device reports its own view of it at run time.

#include "shared/types.h"

typedef struct SelftestParams {
    brdf_f64 scale;  ///< out[i] = scale * i + offset
    brdf_f64 offset;
    brdf_i32 count;  ///< number of outputs written, >= 0
    brdf_i32 flags;  ///< unused; keeps the struct a multiple of 8 bytes
} SelftestParams;
