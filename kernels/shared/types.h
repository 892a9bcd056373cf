#pragma once
// Scalar types for struct layouts shared by host (C++) and device (OpenCL C 1.2). Host code includes
// this as <shared/types.h>; kernels write #include "shared/types.h", which the host-side program
// loader inlines (src/brdf/cl/context.cpp). Use only these types in shared structs, and order fields
// from largest to smallest so host and device agree without padding surprises; the host
// static_asserts every size and offset.

#if defined(__OPENCL_VERSION__)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
typedef int brdf_i32;
typedef uint brdf_u32;
typedef long brdf_i64;
typedef double brdf_f64;
#else
#include <cstdint>
typedef std::int32_t brdf_i32;
typedef std::uint32_t brdf_u32;
typedef std::int64_t brdf_i64;
typedef double brdf_f64;
#endif
