#pragma once
// Layouts of the batched per-order solver kernel (kernels/ambartsumian.cl), shared with the host
// (src/brdf/rte/cl_solver.cpp static_asserts every size and offset). One task per order problem; all
// offsets count doubles from the start of their buffer.
//
// Input of a task (at input_offset): mu[n], w[n], P+[n*n], P-[n*n] (row-major).
// Output (at output_offset): X[n*n], row-major. Workspace (at workspace_offset): AMB_WORKSPACE_MATRICES
// n x n matrices.

#include "shared/types.h"

/// Largest number of streams the kernel accepts (pivot indices live in local memory).
#define AMB_MAX_N 256
/// Largest work-group size the kernel's local reduction arrays hold (a power of two).
#define AMB_MAX_WG 256
/// n x n matrices of workspace per task: the kernels use slots 0..14 (the doubling's iterates, its
/// two n x 2n right-hand sides, the LU and two products).
#define AMB_WORKSPACE_MATRICES 16

/// Task.method: the same numbering as brdf::rte::Method.
#define AMB_FIXED_POINT 0
#define AMB_DOUBLING 1
#define AMB_FAST 2

/// Status.error
#define AMB_OK 0
#define AMB_FIXED_POINT_DIVERGED 1 ///< a fixed-point sweep produced a non-finite X
#define AMB_DOUBLING_DIVERGED 2    ///< a doubling step produced a non-finite H
#define AMB_SINGULAR 3             ///< an LU pivot was zero or not finite (detail: its column)

typedef struct AmbTask {
    brdf_i64 input_offset;     ///< mu, w, P+, P-
    brdf_i64 output_offset;    ///< X
    brdf_i64 workspace_offset; ///< AMB_WORKSPACE_MATRICES * n * n doubles
    brdf_f64 omega;            ///< single-scattering albedo
    brdf_f64 tolerance;        ///< relative stopping tolerance on the iterate's change
    brdf_f64 gamma;            ///< doubling's Cayley parameter
    brdf_i32 n;                ///< streams, 1..AMB_MAX_N
    brdf_i32 m;                ///< Fourier order
    brdf_i32 method;           ///< AMB_FIXED_POINT, AMB_DOUBLING or AMB_FAST
    brdf_i32 max_iterations;   ///< fixed-point sweeps (doubling stops at AMB_DOUBLING_STEPS)
    brdf_i32 fast_sweeps;      ///< AMB_FAST: sweeps before switching to doubling
    brdf_i32 doubling_first;   ///< AMB_FAST: straight to doubling (amb_fast_starts_with_doubling)
} AmbTask;

typedef struct AmbStatus {
    brdf_i32 iterations; ///< as OrderSolution::iterations
    brdf_i32 converged;  ///< 0 or 1
    brdf_i32 error;      ///< AMB_OK or an error code
    brdf_i32 detail;     ///< AMB_SINGULAR: the column of the zero pivot
} AmbStatus;
