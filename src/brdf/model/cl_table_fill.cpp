// Host side of kernels/table_fill.cl: packs FillInputs' arrays into one buffer of doubles, runs one
// work-item per TF_LANES cells and reads the three channel planes (a grey table's one) straight into
// a formats::BrdfTable.

#include <brdf/model/cl_table_fill.h>

#include <algorithm>
#include <thread>

#include <brdf/cl/context.h>
#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>
#include <formats/halfdiff.h>

#include <shared/table_fill_layout.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <vector>

namespace brdf::model {

static_assert(sizeof(FillParams) == 112);
static_assert(offsetof(FillParams, phase_offset) == 0);
static_assert(offsetof(FillParams, refractive_index_offset) == 8);
static_assert(offsetof(FillParams, transmission_offset) == 16);
static_assert(offsetof(FillParams, geometry_offset) == 24);
static_assert(offsetof(FillParams, tau_offset) == 32);
static_assert(offsetof(FillParams, cell_count) == 40);
static_assert(offsetof(FillParams, grid) == 48);
static_assert(offsetof(FillParams, orders) == 52);
static_assert(offsetof(FillParams, samples) == 56);
static_assert(offsetof(FillParams, phase_points) == 60);
static_assert(offsetof(FillParams, fresnel_points) == 64);
static_assert(offsetof(FillParams, channels) == 68);
static_assert(offsetof(FillParams, lobe_fresnel_offset) == 72);
static_assert(offsetof(FillParams, lobe_alpha) == 80);
static_assert(offsetof(FillParams, lobe) == 88);
static_assert(offsetof(FillParams, lobe_separable) == 92);
static_assert(offsetof(FillParams, lobe_points) == 96);
static_assert(offsetof(FillParams, pad2) == 100);
static_assert(offsetof(FillParams, node_blocks_offset) == 104);
static_assert(static_cast<int>(FillInputs::Lobe::Ggx) == 1 && static_cast<int>(FillInputs::Lobe::Beckmann) == 2);
static_assert(TF_CELLS == formats::cells);
static_assert(TF_THETA_H_BINS == formats::theta_h_bins);
static_assert(TF_THETA_D_BINS == formats::theta_d_bins);
static_assert(TF_PHI_D_BINS == formats::phi_d_bins);
static_assert(TF_NO_DATA == formats::BrdfTable::no_data);
static_assert(TF_ORDER_BLOCK == fill_order_block);

namespace {

void require_size(std::size_t have, std::size_t want, const char* what) {
    if (have != want)
        throw InputError(cat("OpenCL table fill: FillInputs::", what, " holds ", have, " values, expected ", want));
}

void validate(const FillInputs& in) {
    if (in.orders < 0 || in.samples < 0) throw InputError("OpenCL table fill: negative orders or samples");
    if (in.orders > 0 && in.grid < 2)
        throw InputError(cat("OpenCL table fill: grid of ", in.grid, " zenith angles (at least 2)"));
    if (in.samples > 0 && (in.phase_points < 5 || in.fresnel_points < 5))
        throw InputError(cat("OpenCL table fill: phase table of ", in.phase_points, " and transmission table of ",
                             in.fresnel_points, " points (at least 5 each)"));
    const auto e = static_cast<std::size_t>(std::max(0, in.grid));
    const auto s = static_cast<std::size_t>(in.samples);
    if (in.channels != 1 && in.channels != 3)
        throw InputError(cat("OpenCL table fill: ", in.channels, " channels (1 or 3)"));
    const auto c = static_cast<std::size_t>(in.channels);
    require_size(in.fourier.size(), static_cast<std::size_t>(padded_orders(in.orders)) * c * e * e, "fourier");
    // The kernel indexes a lane's grid nodes with 32-bit ints (int8 vectors).
    if (in.fourier.size() > static_cast<std::size_t>(std::numeric_limits<int>::max()))
        throw LimitError(cat("OpenCL table fill: ", in.fourier.size(), " Fourier values (at most ",
                             std::numeric_limits<int>::max(), "); use --device cpu"));
    if (in.orders > 0 && !in.node_blocks.empty()) {
        require_size(in.node_blocks.size(), e * e, "node_blocks");
        const int most = padded_orders(in.orders) / fill_order_block;
        for (int b : in.node_blocks)
            if (b < 0 || b > most)
                throw InputError(cat("OpenCL table fill: a node needs ", b, " blocks of orders (0 to ", most, ")"));
    }
    require_size(in.phase.size(), s * static_cast<std::size_t>(std::max(0, in.phase_points)) * c, "phase");
    require_size(in.refractive_index.size(), s, "refractive_index");
    require_size(in.transmission.size(), s * static_cast<std::size_t>(std::max(0, in.fresnel_points)), "transmission");
    require_size(in.tau.size(), s, "tau");
    if (in.lobe != FillInputs::Lobe::None) {
        if (in.lobe != FillInputs::Lobe::Ggx && in.lobe != FillInputs::Lobe::Beckmann)
            throw InputError("OpenCL table fill: unknown lobe distribution");
        if (!(in.lobe_alpha >= 1e-3 && in.lobe_alpha <= 1.0))
            throw InputError(cat("OpenCL table fill: lobe roughness ", in.lobe_alpha, " (0.001 to 1)"));
        if (in.lobe_points < 5)
            throw InputError(cat("OpenCL table fill: lobe Fresnel table of ", in.lobe_points, " points (at least 5)"));
        require_size(in.lobe_fresnel.size(), 3 * static_cast<std::size_t>(in.lobe_points), "lobe_fresnel");
    }
}

// sin and cos of every bin centre, the same for every table: the kernel builds the cells'
// directions from these as formats::to_directions does (the same products, so the same horizon).
std::vector<double> bin_centre_trigonometry() {
    std::vector<double> out;
    const auto add = [&out](double angle) {
        out.push_back(std::sin(angle));
        out.push_back(std::cos(angle));
    };
    for (int i = 0; i < formats::theta_h_bins; ++i) add(formats::theta_h_centre(i));
    for (int j = 0; j < formats::theta_d_bins; ++j) add(formats::theta_d_centre(j));
    for (int k = 0; k < formats::phi_d_bins; ++k) add(formats::phi_d_centre(k));
    return out;
}

} // namespace

formats::BrdfTable fill_table_opencl(const FillInputs& in) {
    validate(in);
    FillParams params{};
    std::vector<double> data;
    data.reserve(in.phase.size() + in.refractive_index.size() + in.transmission.size() + in.tau.size() +
                 in.lobe_fresnel.size() + in.node_blocks.size() +
                 2 * (formats::theta_h_bins + formats::theta_d_bins + formats::phi_d_bins));
    auto append = [&data](const std::vector<double>& v) {
        const auto offset = static_cast<brdf_i64>(data.size());
        data.insert(data.end(), v.begin(), v.end());
        return offset;
    };
    params.phase_offset = append(in.phase);
    params.refractive_index_offset = append(in.refractive_index);
    params.transmission_offset = append(in.transmission);
    params.geometry_offset = append(bin_centre_trigonometry());
    params.tau_offset = append(in.tau);
    params.lobe_fresnel_offset = append(in.lobe_fresnel);
    params.node_blocks_offset = -1;
    if (in.orders > 0 && !in.node_blocks.empty())
        params.node_blocks_offset = append(std::vector<double>(in.node_blocks.begin(), in.node_blocks.end()));
    if (data.empty()) data.push_back(0.0);
    params.cell_count = static_cast<brdf_i64>(formats::cells);
    params.grid = in.grid;
    params.orders = in.orders;
    params.samples = in.samples;
    params.phase_points = in.phase_points;
    params.fresnel_points = in.fresnel_points;
    params.channels = in.channels;
    params.lobe_alpha = in.lobe_alpha;
    params.lobe = static_cast<brdf_i32>(in.lobe);
    params.lobe_separable = in.lobe_separable ? 1 : 0;
    params.lobe_points = in.lobe_points;
    params.pad2 = 0;

    auto ctx = brdf::cl::Context::shared();
    const ::cl::Program program = ctx->program("table_fill");
    cl_int err = CL_SUCCESS;
    ::cl::Kernel kernel(program, "table_fill", &err);
    brdf::cl::check(err, "OpenCL table fill: create kernel table_fill");
    ::cl::Context& context = ctx->context();
    ::cl::Buffer param_buf(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, sizeof(FillParams), &params, &err);
    brdf::cl::check(err, "OpenCL table fill: create buffer parameters");
    ::cl::Buffer data_buf(context, CL_MEM_READ_ONLY | CL_MEM_COPY_HOST_PTR, data.size() * sizeof(double), data.data(),
                          &err);
    brdf::cl::check(err, "OpenCL table fill: create buffer inputs");
    // The orders' grid (4-5 MB at "reference" and "default") read where it lies on a CPU device: it
    // had been copied twice, into `data` and into the device's buffer, on one core while the other
    // waited (3.8 ms of the HG table's 50). A GPU gets its copy. The kernel only reads it.
    static const double no_orders = 0.0;
    const double* grid = in.fourier.empty() ? &no_orders : in.fourier.data();
    const std::size_t grid_bytes = std::max<std::size_t>(1, in.fourier.size()) * sizeof(double);
    const cl_mem_flags in_place = ctx->info().cpu ? CL_MEM_USE_HOST_PTR : CL_MEM_COPY_HOST_PTR;
    ::cl::Buffer fourier_buf(context, CL_MEM_READ_ONLY | in_place, grid_bytes, const_cast<double*>(grid), &err);
    brdf::cl::check(err, "OpenCL table fill: create buffer orders");
    // The kernel writes the table's planes in place where the device can (PoCL on the CPU: no
    // 35 MB device buffer to fault in, nor a copy back); a GPU copies them at the map below. The
    // kernel writes every cell, below the horizon too: the planes start unwritten. A grey fill
    // (one channel) makes a grey table, whose one plane the kernel writes (its green and blue
    // arguments are that plane too, never written).
    const bool grey = in.channels == 1;
    formats::BrdfTable table(formats::BrdfTable::Unwritten{}, grey);
    const std::size_t plane = formats::cells * sizeof(double);
    const int planes = grey ? 1 : 3;
    std::array<::cl::Buffer, 3> out_bufs;
    for (int c = 0; c < planes; ++c) {
        out_bufs[c] = ::cl::Buffer(context, CL_MEM_WRITE_ONLY | CL_MEM_USE_HOST_PTR, plane, table.channels[c].data(),
                                   &err);
        brdf::cl::check(err, "OpenCL table fill: create buffer output");
    }
    brdf::cl::check(kernel.setArg(0, param_buf), "OpenCL table fill: set argument parameters");
    brdf::cl::check(kernel.setArg(1, data_buf), "OpenCL table fill: set argument inputs");
    brdf::cl::check(kernel.setArg(2, fourier_buf), "OpenCL table fill: set argument orders");
    for (int c = 0; c < 3; ++c)
        brdf::cl::check(kernel.setArg(3 + c, out_bufs[grey ? 0 : c]), "OpenCL table fill: set argument output");

    // A work item per TF_LANES cells of the first phi_d half (each writes their mirrors too); the
    // global size is rounded up to a multiple of the local size, and the kernel ignores cells past
    // the half.
    constexpr std::size_t local = 64;
    constexpr std::size_t items = (formats::cells / 2 + TF_LANES - 1) / TF_LANES;
    const std::size_t global = (items + local - 1) / local * local;
    ::cl::CommandQueue& queue = ctx->queue();
    brdf::cl::check(queue.enqueueNDRangeKernel(kernel, ::cl::NullRange, ::cl::NDRange(global), ::cl::NDRange(local)),
                    "OpenCL table fill: run table_fill");
    // Mapping a CL_MEM_USE_HOST_PTR buffer makes the host's memory hold the kernel's results (the
    // pointer returned is the host's own).
    for (int c = 0; c < planes; ++c) {
        void* mapped = queue.enqueueMapBuffer(out_bufs[c], CL_TRUE, CL_MAP_READ, 0, plane, nullptr, nullptr, &err);
        brdf::cl::check(err, "OpenCL table fill: map output");
        if (mapped != table.channels[c].data())
            throw InternalError("OpenCL table fill: the device mapped the output elsewhere than the table");
        brdf::cl::check(queue.enqueueUnmapMemObject(out_bufs[c], mapped), "OpenCL table fill: unmap output");
    }
    brdf::cl::check(queue.finish(), "OpenCL table fill: finish");
    return table;
}

void load_fill_program() { brdf::cl::Context::shared()->program("table_fill"); }

formats::BrdfTable fill_table(const FillInputs& in, Device device) {
    if (device == Device::OpenCL) return fill_table_opencl(in);
    return fill_table_cpu(in, available_cpus());
}

} // namespace brdf::model
