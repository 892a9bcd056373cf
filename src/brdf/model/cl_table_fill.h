#pragma once
// The OpenCL table fill (kernels/table_fill.cl): every cell of the MERL half/difference table from
// FillInputs, one work-item per eight cells (TF_LANES), on brdf::cl::Context::shared(). The C++
// reference is fill_table_reference (table_fill.h); the kernel computes what fill_value computes,
// formula for formula, including the bin-centre geometry and the below-horizon test.

#include <brdf/model/table_fill.h>
#include <formats/table.h>

namespace brdf::model {

/// Every cell of the table on the OpenCL device: cells whose bin centre has the incident or the
/// outgoing direction on or below the horizon hold formats::BrdfTable::no_data in all three
/// channels, every other cell fill_value(in, theta_i, theta_o, phi) of its bin centre (equal to
/// fill_table_reference's to ~1e-12 relative). Throws InputError for inconsistent FillInputs (array
/// sizes, grid < 2, tables with fewer than 2 points), LimitError for a Fourier grid past 32-bit
/// indices, DeviceError on device failure (or without a device).
formats::BrdfTable fill_table_opencl(const FillInputs& in);

/// Builds (or finds in PoCL's cache) the fill's program on the OpenCL device, for a caller that has
/// other work to do meanwhile: fill_table_opencl then finds it built. DeviceError as
/// fill_table_opencl's.
void load_fill_program();

/// fill_table_opencl or fill_table_cpu (on every core) by device.
formats::BrdfTable fill_table(const FillInputs& in, Device device);

} // namespace brdf::model
