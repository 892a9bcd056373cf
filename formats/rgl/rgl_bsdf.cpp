#include <formats/rgl/rgl_bsdf.h>

#include <formats/file_io.h>
#include <formats/rgl/tensor_file.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cmath>
#include <limits>

namespace brdf::formats {

namespace {

using detail::display;

template <typename T> std::string list_text(const std::vector<T>& v) {
    std::string out = "[";
    for (std::size_t d = 0; d < v.size(); ++d) out += cat(d ? ", " : "", v[d]);
    return out + "]";
}

// Product of a shape, or SIZE_MAX when it overflows.
std::size_t checked_product(const std::vector<std::size_t>& shape) {
    std::size_t n = 1;
    for (std::size_t d : shape) {
        if (d != 0 && n > std::numeric_limits<std::size_t>::max() / d)
            return std::numeric_limits<std::size_t>::max();
        n *= d;
    }
    return n;
}

// The multi-index of flat index `k` in `shape`, for messages.
std::string index_text(const std::vector<std::size_t>& shape, std::size_t k) {
    std::vector<std::size_t> index(shape.size());
    for (std::size_t d = shape.size(); d-- > 0;) {
        index[d] = shape[d] ? k % shape[d] : 0;
        k = shape[d] ? k / shape[d] : 0;
    }
    return list_text(index);
}

std::string axis_fault(const char* name, const std::vector<float>& nodes, bool positive) {
    if (nodes.empty()) return cat("field '", name, "': no values");
    for (std::size_t k = 0; k < nodes.size(); ++k) {
        if (!std::isfinite(nodes[k]))
            return cat("field '", name, "': non-finite value ", detail::value_text(nodes[k]),
                       " at index [", k, "]");
        if (positive && !(nodes[k] > 0.0f))
            return cat("field '", name, "': value ", nodes[k], " at index [", k, "] is not > 0");
        if (k > 0 && !(nodes[k] > nodes[k - 1]))
            return cat("field '", name, "': not increasing (", nodes[k - 1], " then ", nodes[k],
                       " at index [", k, "])");
    }
    return {};
}

// Rank and minimum extents; `expected` entries of 0 are free, the others must match.
std::string shape_fault(const char* name, const RglArray& a, std::size_t rank,
                        const std::vector<std::size_t>& expected,
                        const std::vector<const char*>& expected_from) {
    if (a.shape.size() != rank)
        return cat("field '", name, "': rank ", a.shape.size(), " (", rank, " expected: shape ",
                   list_text(a.shape), ")");
    for (std::size_t d = 0; d < rank; ++d) {
        if (expected[d] != 0 && a.shape[d] != expected[d])
            return cat("field '", name, "': shape ", list_text(a.shape), " does not match ",
                       expected_from[d], " (", expected[d], " values) in dimension ", d);
        if (expected[d] == 0 && a.shape[d] < 2)
            return cat("field '", name, "': shape ", list_text(a.shape), ": dimension ", d,
                       " needs at least 2 nodes");
    }
    if (checked_product(a.shape) != a.values.size())
        return cat("field '", name, "': shape ", list_text(a.shape), " does not hold ",
                   a.values.size(), " values");
    return {};
}

// Finite everywhere; `min_kind`: 0 any, 1 >= 0, 2 > 0.
std::string value_fault(const char* name, const RglArray& a, int min_kind) {
    for (std::size_t k = 0; k < a.values.size(); ++k) {
        const float v = a.values[k];
        if (!std::isfinite(v))
            return cat("field '", name, "': non-finite value ", detail::value_text(v), " at index ",
                       index_text(a.shape, k));
        if ((min_kind == 1 && v < 0.0f) || (min_kind == 2 && !(v > 0.0f)))
            return cat("field '", name, "': value ", v, " at index ", index_text(a.shape, k),
                       min_kind == 1 ? " is negative" : " is not > 0");
    }
    return {};
}

// A warp ([P, T, rows, columns], values >= 0): the renderers normalise each grid in single precision
// and divide by the integral of each row when they invert it, so every row needs a positive value
// and every grid an integral that 1 / integral does not overflow.
std::string warp_fault(const char* name, const RglArray& a) {
    const std::size_t rows = a.shape[2], columns = a.shape[3], grid = rows * columns;
    for (std::size_t start = 0; start + grid <= a.values.size(); start += grid) {
        double integral = 0.0;
        for (std::size_t r = 0; r < rows; ++r) {
            const float* row = a.values.data() + start + r * columns;
            if (std::all_of(row, row + columns, [](float v) { return v == 0.0f; }))
                return cat("field '", name, "': row ", r, " of the grid at index ",
                           index_text(a.shape, start),
                           " is zero (the renderers divide by each row's integral)");
            for (std::size_t c = 0; c + 1 < columns; ++c)
                integral += (double{row[c]} + row[c + 1]) * (r == 0 || r + 1 == rows ? 0.5 : 1.0);
        }
        integral *= 0.5 / ((columns - 1) * (rows - 1));
        if (!(integral >= 1e-30))
            return cat("field '", name, "': the grid at index ", index_text(a.shape, start),
                       " integrates to ", integral, ", too little to normalise in single precision");
    }
    return {};
}

double largest(const std::vector<float>& v) {
    double m = 0.0;
    for (float x : v) m = std::max(m, std::abs(double{x}));
    return m;
}

RglArray array_of(const TensorField& f) {
    RglArray a;
    a.shape.assign(f.shape.begin(), f.shape.end());
    a.values = f.to_float32();
    return a;
}

} // namespace

std::size_t RglArray::size() const {
    return checked_product(shape);
}

std::string rgl_bsdf_fault(const RglBsdf& b) {
    std::string fault;
    if (!(fault = axis_fault("theta_i", b.theta_i, false)).empty()) return fault;
    if (!(fault = axis_fault("phi_i", b.phi_i, false)).empty()) return fault;
    if (b.spectral() && !(fault = axis_fault("wavelengths", b.wavelengths, true)).empty())
        return fault;
    const std::size_t P = b.phi_i.size(), T = b.theta_i.size(), L = b.channels();
    const char* values_name = b.spectral() ? "spectra" : "rgb";
    if (!(fault = shape_fault("ndf", b.ndf, 2, {0, 0}, {"", ""})).empty()) return fault;
    if (!(fault = shape_fault("sigma", b.sigma, 2, {0, 0}, {"", ""})).empty()) return fault;
    if (!(fault = shape_fault("vndf", b.vndf, 4, {P, T, 0, 0}, {"phi_i", "theta_i", "", ""}))
             .empty())
        return fault;
    if (!(fault = shape_fault("luminance", b.luminance, 4, {P, T, 0, 0},
                              {"phi_i", "theta_i", "", ""}))
             .empty())
        return fault;
    if (b.luminance.shape[2] != b.luminance.shape[3])
        return cat("field 'luminance': shape ", list_text(b.luminance.shape),
                   ": the sample grid is not square");
    const std::size_t n = b.luminance.shape[2];
    if (!(fault = shape_fault(values_name, b.values, 5, {P, T, L, n, n},
                              {"phi_i", "theta_i", b.spectral() ? "wavelengths" : "RGB",
                               "luminance", "luminance"}))
             .empty())
        return fault;
    if (!(fault = value_fault("ndf", b.ndf, 1)).empty()) return fault;
    if (!(fault = value_fault("sigma", b.sigma, 2)).empty()) return fault;
    if (!(fault = value_fault("vndf", b.vndf, 1)).empty()) return fault;
    if (!(fault = value_fault("luminance", b.luminance, 1)).empty()) return fault;
    if (!(fault = value_fault(values_name, b.values, 0)).empty()) return fault;
    if (!(fault = warp_fault("vndf", b.vndf)).empty()) return fault;
    if (!(fault = warp_fault("luminance", b.luminance)).empty()) return fault;
    // A renderer's value is a sample times ndf / (4 sigma), all interpolated between the nodes:
    // bounded by the largest of each and the smallest sigma, which must stay a float.
    if (b.jacobian) {
        const double bound = largest(b.values.values) * largest(b.ndf.values) /
                             (4.0 * *std::min_element(b.sigma.values.begin(), b.sigma.values.end()));
        if (!(bound <= std::numeric_limits<float>::max()))
            return cat("field '", values_name, "': the largest sample times the largest ndf over 4 "
                       "times the smallest sigma is ", bound, ", beyond single precision");
    }
    return {};
}

RglBsdf read_rgl_bsdf(const std::filesystem::path& path) {
    const TensorFile file = read_tensor_file(path);
    const std::string where = display(path);
    const auto field = [&](const char* name, TensorDType dtype,
                           std::size_t rank) -> const TensorField& {
        const TensorField* f = file.find(name);
        if (!f)
            throw FormatError(cat(where, ": field '", name,
                                  "' is missing (not an RGL BSDF file)"));
        if (f->dtype != dtype || f->shape.size() != rank)
            throw FormatError(cat(where, ": field '", name, "': ", to_string(f->dtype),
                                  " of rank ", f->shape.size(), " (", to_string(dtype),
                                  " of rank ", rank, " expected)"));
        return *f;
    };
    constexpr auto f32 = TensorDType::Float32;
    RglBsdf b;
    b.theta_i = field("theta_i", f32, 1).to_float32();
    b.phi_i = field("phi_i", f32, 1).to_float32();
    b.ndf = array_of(field("ndf", f32, 2));
    b.sigma = array_of(field("sigma", f32, 2));
    b.vndf = array_of(field("vndf", f32, 4));
    b.luminance = array_of(field("luminance", f32, 4));
    if (file.find("wavelengths")) {
        b.wavelengths = field("wavelengths", f32, 1).to_float32();
        b.values = array_of(field("spectra", f32, 5));
    } else {
        if (!file.find("rgb") && file.find("spectra"))
            throw FormatError(cat(where, ": field 'wavelengths' is missing (a spectral file "
                                         "needs it beside 'spectra')"));
        b.values = array_of(field("rgb", f32, 5));
    }
    const TensorField& description = field("description", TensorDType::UInt8, 1);
    b.description.assign(description.bytes.begin(), description.bytes.end());
    const TensorField& jacobian = field("jacobian", TensorDType::UInt8, 1);
    if (jacobian.shape[0] != 1)
        throw FormatError(cat(where, ": field 'jacobian': shape ", list_text(jacobian.shape),
                              " ([1] expected)"));
    b.jacobian = jacobian.bytes[0] != 0;
    if (const std::string fault = rgl_bsdf_fault(b); !fault.empty())
        throw FormatError(cat(where, ": ", fault));
    return b;
}

void write_rgl_bsdf(const std::filesystem::path& path, const RglBsdf& b) {
    const std::string where = display(path);
    if (const std::string fault = rgl_bsdf_fault(b); !fault.empty())
        throw NumericalError(cat(where, ": ", fault));
    for (std::size_t k = 0; k < b.values.values.size(); ++k)
        if (b.values.values[k] < 0.0f)
            throw NumericalError(cat(where, ": field '", b.spectral() ? "spectra" : "rgb",
                                     "': value ", b.values.values[k], " at index ",
                                     index_text(b.values.shape, k), " is negative"));
    write_tensor_file(path, rgl_tensor_fields(b));
}

TensorFile rgl_tensor_fields(const RglBsdf& b) {
    const auto shape64 = [](const std::vector<std::size_t>& s) {
        return std::vector<std::uint64_t>(s.begin(), s.end());
    };
    TensorFile file;
    file.fields.push_back(TensorField::float32("theta_i", {b.theta_i.size()}, b.theta_i));
    file.fields.push_back(TensorField::float32("phi_i", {b.phi_i.size()}, b.phi_i));
    file.fields.push_back(TensorField::float32("ndf", shape64(b.ndf.shape), b.ndf.values));
    file.fields.push_back(TensorField::float32("sigma", shape64(b.sigma.shape), b.sigma.values));
    file.fields.push_back(TensorField::float32("vndf", shape64(b.vndf.shape), b.vndf.values));
    file.fields.push_back(
        TensorField::float32("luminance", shape64(b.luminance.shape), b.luminance.values));
    if (b.spectral()) {
        file.fields.push_back(
            TensorField::float32("spectra", shape64(b.values.shape), b.values.values));
        file.fields.push_back(
            TensorField::float32("wavelengths", {b.wavelengths.size()}, b.wavelengths));
    } else {
        file.fields.push_back(TensorField::float32("rgb", shape64(b.values.shape), b.values.values));
    }
    file.fields.push_back(TensorField::uint8(
        "description", {b.description.size()},
        std::vector<unsigned char>(b.description.begin(), b.description.end())));
    file.fields.push_back(TensorField::uint8(
        "jacobian", {1}, {static_cast<unsigned char>(b.jacobian ? 1 : 0)}));
    return file;
}

} // namespace brdf::formats
