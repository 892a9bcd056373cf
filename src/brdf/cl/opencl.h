#pragma once
// The one way to include the Khronos C++ bindings: every file that uses ::cl:: includes this
// header, never <CL/opencl.hpp> directly, so all translation units agree on the settings below.
//
// The bindings do not throw (CL_HPP_ENABLE_EXCEPTIONS stays undefined): calls return a cl_int or
// take a cl_int* and callers pass it to brdf::cl::check(), so every failure leaves as a
// brdf::DeviceError that names what failed, never as a ::cl::Error that the tools' main would not
// recognise.

#if defined(CL_HPP_ENABLE_EXCEPTIONS)
#error "brdf-service uses the OpenCL C++ bindings without exceptions (see brdf/cl/opencl.h)"
#endif

// Kernels are built as OpenCL C 1.2 (-cl-std=CL1.2) and the host needs no newer API.
#define CL_HPP_TARGET_OPENCL_VERSION 120
#define CL_HPP_MINIMUM_OPENCL_VERSION 120

#include <CL/opencl.hpp>
