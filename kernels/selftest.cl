// Self-test kernels: prove that the device builds our programs, runs double precision and sees the
// shared struct layout as the host does (src/brdf/cl/self_test.cpp holds the C++ reference).

#include "shared/selftest_layout.h"

/// y[i] = a * x[i] + y[i] for i < n.
__kernel void selftest_axpy(const double a, __global const double* x, __global double* y,
                            const int n) {
    const int i = (int)get_global_id(0);
    if (i < n) y[i] = a * x[i] + y[i];
}

/// out[i] = p->scale * i + p->offset for i < p->count; work-item 0 also writes the device's view of
/// the layout to layout[0..4]: sizeof, then the offsets of scale, offset, count, flags.
__kernel void selftest_layout(__global const SelftestParams* p, __global double* out,
                              __global long* layout) {
    const int i = (int)get_global_id(0);
    if (i < p->count) out[i] = p->scale * (double)i + p->offset;
    if (i == 0) {
        __global const char* base = (__global const char*)p;
        layout[0] = (long)sizeof(SelftestParams);
        layout[1] = (long)((__global const char*)&p->scale - base);
        layout[2] = (long)((__global const char*)&p->offset - base);
        layout[3] = (long)((__global const char*)&p->count - base);
        layout[4] = (long)((__global const char*)&p->flags - base);
    }
}
