#include <formats/fourier/fourier.h>

#include <formats/file_io.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/core/threads.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <bit>
#include <charconv>
#include <cmath>
#include <cstring>
#include <limits>
#include <optional>

namespace brdf::formats {

namespace {

using detail::display;

// --- Little-endian fields
// -------------------------------------------------------------------------

std::uint32_t load_u32(const unsigned char* p) {
    return std::uint32_t{p[0]} | std::uint32_t{p[1]} << 8 | std::uint32_t{p[2]} << 16 |
           std::uint32_t{p[3]} << 24;
}
float load_f32(const unsigned char* p) {
    return std::bit_cast<float>(load_u32(p));
}
void store_u32(unsigned char* p, std::uint32_t v) {
    for (int b = 0; b < 4; ++b) p[b] = static_cast<unsigned char>(v >> (8 * b));
}
void store_f32(unsigned char* p, float v) {
    store_u32(p, std::bit_cast<std::uint32_t>(v));
}

// Header field offsets (pbrt-v3 materials/fourier.cpp; layerlab storage.h, struct Header).
constexpr std::size_t off_flags = 8, off_nodes = 12, off_coeffs = 16, off_max_order = 20,
                      off_channels = 24, off_bases = 28, off_metadata = 32, off_parameters = 36,
                      off_parameter_values = 40, off_eta = 44, off_alpha = 48;

// Bytes the counts of a header imply, in 128 bits: a forged node count squared overflows 64.
__extension__ typedef unsigned __int128 Uint128;

Uint128 implied_size(std::uint64_t nodes, std::uint64_t coeffs, std::uint64_t metadata) {
    const Uint128 n = nodes;
    return fourier_header_size + 4 * n + 4 * n * n + 8 * n * n + 4 * Uint128{coeffs} + metadata;
}

std::string u128_text(Uint128 v) {
    if (v == 0) return "0";
    std::string s;
    while (v > 0) {
        s.insert(s.begin(), static_cast<char>('0' + static_cast<int>(v % 10)));
        v /= 10;
    }
    return s;
}

// --- Catmull-Rom in mu (PBR book section 8.6.1, CatmullRomWeights)
// --------------------------------

struct SplineWeights {
    int offset = 0; ///< node of weights[0]; weights[k] belongs to node offset + k
    std::array<double, 4> weights{};
};

// The nodes' interval holding x and the weights of its four nodes: a cubic Hermite segment whose
// tangents are finite differences over the neighbouring nodes (one-sided at the ends). Empty
// outside [nodes.front(), nodes.back()] (also for NaN), as pbrt-v3 returns false there.
std::optional<SplineWeights> spline_weights(std::span<const float> nodes, double x) {
    const int n = static_cast<int>(nodes.size());
    if (!(x >= nodes.front() && x <= nodes.back())) return std::nullopt;
    // The last node <= x, kept in [0, n - 2] (pbrt-v3's FindInterval).
    const auto upper = std::upper_bound(nodes.begin(), nodes.end(), x,
                                        [](double v, float node) { return v < node; });
    const int idx = std::clamp(static_cast<int>(upper - nodes.begin()) - 1, 0, n - 2);
    const double x0 = nodes[idx], x1 = nodes[idx + 1];
    const double t = (x - x0) / (x1 - x0), t2 = t * t, t3 = t2 * t;
    SplineWeights w;
    w.offset = idx - 1;
    w.weights[1] = 2 * t3 - 3 * t2 + 1;
    w.weights[2] = -2 * t3 + 3 * t2;
    if (idx > 0) {
        const double w0 = (t3 - 2 * t2 + t) * (x1 - x0) / (x1 - nodes[idx - 1]);
        w.weights[0] = -w0;
        w.weights[2] += w0;
    } else {
        const double w0 = t3 - 2 * t2 + t;
        w.weights[0] = 0;
        w.weights[1] -= w0;
        w.weights[2] += w0;
    }
    if (idx + 2 < n) {
        const double w3 = (t3 - t2) * (x1 - x0) / (nodes[idx + 2] - x0);
        w.weights[1] -= w3;
        w.weights[3] = w3;
    } else {
        const double w3 = t3 - t2;
        w.weights[1] -= w3;
        w.weights[2] += w3;
        w.weights[3] = 0;
    }
    return w;
}

// sum_{k < m} a_k cos(k phi) from cos phi by the Chebyshev recurrence cos((k+1) phi) = 2 cos phi
// cos(k phi) - cos((k-1) phi) (pbrt-v3's Fourier()).
double fourier_sum(const double* a, std::size_t m, double cos_phi) {
    double value = 0.0, previous = cos_phi, current = 1.0;
    for (std::size_t k = 0; k < m; ++k) {
        value += a[k] * current;
        const double next = 2 * cos_phi * current - previous;
        previous = current;
        current = next;
    }
    return value;
}

// --- Validation
// -----------------------------------------------------------------------------------

struct Fault {
    bool numerical = false; ///< a non-finite value (NumericalError when writing)
    std::string message;
};

// The shortest decimal that reads back as the same float (0.9f is "0.9", not "0.8999999762").
std::string float_text(float v) {
    if (!std::isfinite(v)) return detail::value_text(v);
    char buffer[32];
    const auto end = std::to_chars(buffer, buffer + sizeof buffer, v).ptr;
    return std::string(buffer, end);
}

std::string pair_text(const FourierBsdf& b, std::size_t o, std::size_t i) {
    return cat("pair o ", o, ", i ", i, " (mu_o ", float_text(b.mu[o]), ", mu_i ",
               float_text(b.mu[i]), ")");
}

std::optional<Fault> find_fault(const FourierBsdf& b) {
    const std::size_t n = b.mu.size();
    if (n < 2) return Fault{false, cat(n, " nodes (at least 2 needed)")};
    for (std::size_t k = 0; k < n; ++k) {
        const float m = b.mu[k];
        if (!std::isfinite(m))
            return Fault{true, cat("non-finite node mu[", k, "] = ", detail::value_text(m))};
        if (m < -1.0f || m > 1.0f)
            return Fault{false, cat("node mu[", k, "] = ", float_text(m), " outside [-1, 1]")};
        if (k > 0 && m < b.mu[k - 1])
            return Fault{false, cat("nodes not in increasing order (mu[", k - 1,
                                    "] = ", float_text(b.mu[k - 1]), ", mu[", k,
                                    "] = ", float_text(m), ")")};
    }
    if (!(b.mu.front() < b.mu.back()))
        return Fault{false, cat("all nodes equal (", float_text(b.mu.front()), ")")};
    // At mu = mu.back() the spline's interval is the last one; of zero width it divides 0 by 0 (and
    // pbrt-v3 then reads outside its tables).
    if (b.mu[n - 2] == b.mu[n - 1])
        return Fault{false, cat("the last two nodes are equal (", float_text(b.mu[n - 1]),
                                "): the last spline interval has zero width")};
    if (b.channels != 1 && b.channels != 3)
        return Fault{false, cat(b.channels, " channels (pbrt-v3 reads 1 or 3)")};
    if (!std::isfinite(b.eta))
        return Fault{true, cat("non-finite eta ", detail::value_text(b.eta))};
    if (!(b.eta > 0.0f)) return Fault{false, cat("eta ", float_text(b.eta), " (must be > 0)")};
    if (b.series.size() != n * n)
        return Fault{false,
                     cat(b.series.size(), " series for ", n, " nodes (", n * n, " expected)")};
    if (b.cdf.size() != n * n)
        return Fault{false,
                     cat(b.cdf.size(), " cdf values for ", n, " nodes (", n * n, " expected)")};
    const std::uint64_t total = b.coefficients.size();
    std::uint32_t longest = 0;
    for (std::size_t o = 0; o < n; ++o)
        for (std::size_t i = 0; i < n; ++i) {
            const FourierBsdf::Series& s = b.at(o, i);
            const std::uint64_t end =
                std::uint64_t{s.offset} + std::uint64_t{s.length} * std::uint64_t(b.channels);
            if (end > total)
                return Fault{false, cat("series of ", pair_text(b, o, i),
                                        " runs past the coefficients (offset ", s.offset, " + ",
                                        b.channels, " x ", s.length, " > ", total, ")")};
            if (s.length > b.max_order)
                return Fault{false, cat("series of ", pair_text(b, o, i), " has ", s.length,
                                        " coefficients, more than mMax = ", b.max_order)};
            longest = std::max(longest, s.length);
        }
    if (longest != b.max_order)
        return Fault{false, cat("mMax is ", b.max_order, " but the longest series has ", longest,
                                " coefficients")};
    for (std::size_t k = 0; k < total; ++k)
        if (!std::isfinite(b.coefficients[k]))
            return Fault{true, cat("non-finite coefficient ", detail::value_text(b.coefficients[k]),
                                   " at index ", k)};
    for (std::size_t k = 0; k < b.cdf.size(); ++k)
        if (!std::isfinite(b.cdf[k]))
            return Fault{true, cat("non-finite cdf value ", detail::value_text(b.cdf[k]), " of ",
                                   pair_text(b, k / n, k % n))};
    return std::nullopt;
}

// Our metadata's description of the data's convention, for whoever opens the file.
constexpr const char* convention_text =
    "pbrt-v3 FourierBSDF: a_k(mu_i, mu_o) = coefficients of f(mu_i, mu_o, phi') |mu_i| in "
    "cos(k phi'), mu_i = cos(-wi), mu_o = cos(wo), phi' = azimuth between -wi and wo (0: mirror "
    "side); channels Y, R, B; reflection only (mu_i < 0 < mu_o)";

} // namespace

std::span<const float> FourierBsdf::coefficients_of(std::size_t o, std::size_t i,
                                                    int channel) const {
    const Series& s = at(o, i);
    return {coefficients.data() + s.offset + std::size_t(channel) * s.length, s.length};
}

std::string fourier_provenance_metadata(const std::string& spec, const std::string& generator,
                                        const std::string& colorspace) {
    nlohmann::ordered_json j;
    j["brdf.generator"] = generator;
    j["brdf.spec"] = spec;
    j["brdf.colorspace"] = colorspace;
    j["brdf.units"] = "1/sr";
    j["brdf.convention"] = convention_text;
    // Replace invalid UTF-8 rather than throw: provenance must never stop a table being written.
    return j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace);
}

FourierProvenance fourier_provenance(const FourierBsdf& bsdf) {
    FourierProvenance p;
    const nlohmann::json j = nlohmann::json::parse(bsdf.metadata, nullptr, false);
    if (j.is_discarded() || !j.is_object()) return p;
    const auto text = [&](const char* key, std::string& out) {
        const auto it = j.find(key);
        if (it == j.end() || !it->is_string()) return false;
        out = it->get<std::string>();
        return true;
    };
    const bool generator = text("brdf.generator", p.generator);
    const bool spec = text("brdf.spec", p.spec);
    text("brdf.colorspace", p.colorspace);
    p.ours = generator || spec;
    return p;
}

void check_fourier_bsdf(const FourierBsdf& bsdf, const std::string& what) {
    if (const auto fault = find_fault(bsdf)) throw FormatError(cat(what, ": ", fault->message));
}

FourierBsdf read_fourier_bsdf(const std::filesystem::path& path) {
    const detail::InputFile file(path);
    const std::uint64_t size = file.size();
    const std::string where = display(path);
    if (size == 0) throw FormatError(cat(where, ": empty file (not a Fourier BSDF)"));
    unsigned char h[fourier_header_size];
    const std::size_t got = file.read_at(0, h, std::min<std::uint64_t>(size, fourier_header_size));
    if (got < 7 || std::memcmp(h, fourier_magic.data(), 7) != 0)
        throw FormatError(cat(where, ": not a Fourier BSDF file (no \"SCATFUN\" magic)"));
    if (got < fourier_header_size)
        throw FormatError(cat(where, ": truncated header (", fourier_header_size,
                              " bytes expected, ", got, " found)"));
    if (h[7] != static_cast<unsigned char>(fourier_magic[7]))
        throw FormatError(
            cat(where, ": unsupported SCATFUN version ", int(h[7]), " (pbrt-v3 reads version 1)"));
    const std::uint32_t flags = load_u32(h + off_flags);
    if (flags != fourier_flag_bsdf) {
        if (flags & fourier_flag_extrapolated)
            throw FormatError(cat(where, ": harmonic extrapolation (flags 0x", std::hex, flags,
                                  ") is not supported (pbrt-v3 reads flags 0x1 only)"));
        throw FormatError(cat(where, ": unsupported flags 0x", std::hex, flags,
                              " (pbrt-v3 reads flags 0x1: a BSDF)"));
    }
    const std::uint32_t nodes = load_u32(h + off_nodes), coeffs = load_u32(h + off_coeffs),
                        max_order = load_u32(h + off_max_order),
                        channels = load_u32(h + off_channels), bases = load_u32(h + off_bases),
                        metadata = load_u32(h + off_metadata),
                        parameters = load_u32(h + off_parameters),
                        parameter_values = load_u32(h + off_parameter_values);
    if (channels != 1 && channels != 3)
        throw FormatError(cat(where, ": ", channels, " channels (pbrt-v3 reads 1 or 3)"));
    if (bases != 1 || parameters != 0 || parameter_values != 0)
        throw FormatError(
            cat(where, ": textured BSDF (", bases, " bases, ", parameters,
                " parameters) is not supported (pbrt-v3 reads 1 basis, no parameters)"));
    if (nodes < 2) throw FormatError(cat(where, ": ", nodes, " nodes (at least 2 needed)"));
    // pbrt-v3 reads the counts as int32: larger ones it would misread.
    constexpr std::uint32_t int_max = std::numeric_limits<std::int32_t>::max();
    if (nodes > int_max || coeffs > int_max || max_order > int_max || metadata > int_max)
        throw FormatError(cat(where, ": header counts out of range (", nodes, " nodes, ", coeffs,
                              " coefficients, mMax ", max_order, ", ", metadata,
                              " metadata bytes; pbrt-v3 reads int32)"));
    // Only a file that holds every byte the counts imply is read: this bounds every allocation.
    const Uint128 expected = implied_size(nodes, coeffs, metadata);
    const std::string counts =
        cat(nodes, " nodes, ", coeffs, " coefficients, ", metadata, " metadata bytes");
    if (expected > size)
        throw FormatError(cat(where, ": truncated (", u128_text(expected),
                              " bytes expected from the header: ", counts, "; ", size, " found)"));
    if (expected < size)
        throw FormatError(cat(where, ": wrong size (", u128_text(expected),
                              " bytes expected from the header: ", counts, "; ", size, " found)"));

    std::vector<unsigned char> body(static_cast<std::size_t>(size - fourier_header_size));
    if (file.read_at(fourier_header_size, body.data(), body.size()) != body.size())
        throw FormatError(cat(where, ": truncated while reading (the file changed)"));

    FourierBsdf b;
    b.channels = static_cast<int>(channels);
    b.max_order = max_order;
    b.eta = load_f32(h + off_eta);
    b.alpha = {load_f32(h + off_alpha), load_f32(h + off_alpha + 4)};
    const std::size_t n = nodes, pairs = std::size_t{nodes} * nodes;
    const unsigned char* p = body.data();
    b.mu.resize(n);
    for (std::size_t k = 0; k < n; ++k, p += 4) b.mu[k] = load_f32(p);
    b.cdf.resize(pairs);
    for (std::size_t k = 0; k < pairs; ++k, p += 4) b.cdf[k] = load_f32(p);
    b.series.resize(pairs);
    for (std::size_t k = 0; k < pairs; ++k, p += 8) {
        const std::uint32_t offset = load_u32(p), length = load_u32(p + 4);
        // pbrt-v3 reads both as int32; a "negative" one is out of range for it.
        if (offset > int_max || length > int_max)
            throw FormatError(cat(where, ": series of ", pair_text(b, k / n, k % n), " has offset ",
                                  static_cast<std::int32_t>(offset), " and length ",
                                  static_cast<std::int32_t>(length), " (must be >= 0)"));
        b.series[k] = {offset, length};
    }
    b.coefficients.resize(coeffs);
    for (std::size_t k = 0; k < coeffs; ++k, p += 4) b.coefficients[k] = load_f32(p);
    b.metadata.assign(reinterpret_cast<const char*>(p), metadata);
    if (const auto fault = find_fault(b)) throw FormatError(cat(where, ": ", fault->message));
    return b;
}

void write_fourier_bsdf(const std::filesystem::path& path, const FourierBsdf& b) {
    if (const auto fault = find_fault(b)) {
        if (fault->numerical) throw NumericalError(cat(display(path), ": ", fault->message));
        throw InputError(cat(display(path), ": cannot write: ", fault->message));
    }
    constexpr std::uint64_t int_max = std::numeric_limits<std::int32_t>::max();
    if (b.coefficients.size() > int_max || b.mu.size() > int_max || b.metadata.size() > int_max)
        throw LimitError(cat(display(path), ": too large for pbrt-v3's int32 counts (",
                             b.coefficients.size(), " coefficients)"));
    const std::size_t n = b.mu.size(), pairs = n * n;
    const auto total =
        static_cast<std::size_t>(implied_size(n, b.coefficients.size(), b.metadata.size()));
    unsigned char h[fourier_header_size] = {};
    std::memcpy(h, fourier_magic.data(), fourier_magic.size());
    store_u32(h + off_flags, fourier_flag_bsdf);
    store_u32(h + off_nodes, static_cast<std::uint32_t>(n));
    store_u32(h + off_coeffs, static_cast<std::uint32_t>(b.coefficients.size()));
    store_u32(h + off_max_order, b.max_order);
    store_u32(h + off_channels, static_cast<std::uint32_t>(b.channels));
    store_u32(h + off_bases, 1);
    store_u32(h + off_metadata, static_cast<std::uint32_t>(b.metadata.size()));
    store_u32(h + off_parameters, 0);
    store_u32(h + off_parameter_values, 0);
    store_f32(h + off_eta, b.eta);
    store_f32(h + off_alpha, b.alpha[0]);
    store_f32(h + off_alpha + 4, b.alpha[1]);
    std::vector<unsigned char> body(total - fourier_header_size);
    unsigned char* p = body.data();
    for (float m : b.mu) store_f32(p, m), p += 4;
    for (float c : b.cdf) store_f32(p, c), p += 4;
    for (std::size_t k = 0; k < pairs; ++k, p += 8) {
        store_u32(p, b.series[k].offset);
        store_u32(p + 4, b.series[k].length);
    }
    for (float c : b.coefficients) store_f32(p, c), p += 4;
    std::copy(b.metadata.begin(), b.metadata.end(), p);

    detail::AtomicFile out(path);
    out.write_at(0, h, fourier_header_size);
    out.write_at(fourier_header_size, body.data(), body.size());
    out.commit();
}

Rgb evaluate_pbrt(const FourierBsdf& b, double mu_i, double mu_o, double cos_phi, bool radiance) {
    const auto wi = spline_weights(b.mu, mu_i), wo = spline_weights(b.mu, mu_o);
    if (!wi || !wo) return {0.0, 0.0, 0.0};
    const std::size_t n = b.mu.size(), stride = std::max<std::size_t>(b.max_order, 1);
    // One accumulator per thread: tabulate_fourier evaluates 1.1 million cells.
    thread_local std::vector<double> ak;
    ak.assign(std::size_t(b.channels) * stride, 0.0);
    std::size_t m = 0;
    for (int bo = 0; bo < 4; ++bo)
        for (int ai = 0; ai < 4; ++ai) {
            const double weight = wi->weights[ai] * wo->weights[bo];
            if (weight == 0.0) continue;
            const int o = wo->offset + bo, i = wi->offset + ai;
            if (o < 0 || i < 0 || std::size_t(o) >= n || std::size_t(i) >= n) continue;
            const FourierBsdf::Series& s = b.at(std::size_t(o), std::size_t(i));
            m = std::max<std::size_t>(m, s.length);
            const float* a = b.coefficients.data() + s.offset;
            for (int c = 0; c < b.channels; ++c)
                for (std::size_t k = 0; k < s.length; ++k)
                    ak[c * stride + k] += weight * a[c * s.length + k];
        }
    const double y = std::max(0.0, fourier_sum(ak.data(), m, cos_phi));
    double scale = std::abs(mu_i) > 1e-12 ? 1.0 / std::abs(mu_i) : 0.0;
    if (radiance && mu_i * mu_o > 0.0) {
        const double eta = mu_i > 0.0 ? 1.0 / b.eta : b.eta;
        scale *= eta * eta;
    }
    if (b.channels == 1) return {y * scale, y * scale, y * scale};
    const double r = fourier_sum(ak.data() + stride, m, cos_phi);
    const double bl = fourier_sum(ak.data() + 2 * stride, m, cos_phi);
    const double g = 1.39829 * y - 0.100913 * bl - 0.297375 * r;
    return {std::max(0.0, r * scale), std::max(0.0, g * scale), std::max(0.0, bl * scale)};
}

Rgb evaluate(const FourierBsdf& bsdf, double theta_i, double theta_o, double phi) {
    // -wi has azimuth phi_i + pi, so the azimuth between -wi and wo is pi - phi.
    const bool vertical = std::sin(theta_i) == 0.0 || std::sin(theta_o) == 0.0;
    return evaluate_pbrt(bsdf, -std::cos(theta_i), std::cos(theta_o),
                         vertical ? 1.0 : -std::cos(phi));
}

Rgb evaluate(const FourierBsdf& bsdf, const Vec3& wi, const Vec3& wo) {
    // pbrt-v3's CosDPhi(-wi, wo).
    const double a = wi.x * wi.x + wi.y * wi.y, c = wo.x * wo.x + wo.y * wo.y;
    const double cos_phi =
        a == 0.0 || c == 0.0
            ? 1.0
            : std::clamp((-wi.x * wo.x - wi.y * wo.y) / std::sqrt(a * c), -1.0, 1.0);
    return evaluate_pbrt(bsdf, -wi.z, wo.z, cos_phi);
}

BrdfTable tabulate_fourier(const FourierBsdf& bsdf) {
    BrdfTable table;
    // Rows of theta_h in parallel; each cell is written once, so the table does not depend on the
    // thread count. The centres are those of tabulate().
    parallel_for(theta_h_bins, 0, [&](int i) {
        for (int j = 0; j < theta_d_bins; ++j)
            for (int k = 0; k < phi_d_bins; ++k) {
                const std::size_t cell = cell_index(i, j, k);
                if (cell_below_horizon(cell)) continue;
                const DirectionPair d =
                    to_directions(theta_h_centre(i), theta_d_centre(j), phi_d_centre(k));
                table.set(cell, evaluate(bsdf, d.wi, d.wo));
            }
    });
    const FourierProvenance p = fourier_provenance(bsdf);
    table.spec = p.spec;
    table.generator = p.generator;
    if (!p.colorspace.empty()) table.colorspace = p.colorspace;
    return table;
}

double integrate_catmull_rom(std::span<const double> x, std::span<const double> f,
                             std::span<double> cdf) {
    const std::size_t n = x.size();
    double sum = 0.0;
    if (n == 0) return 0.0;
    cdf[0] = 0.0;
    for (std::size_t i = 0; i + 1 < n; ++i) {
        const double width = x[i + 1] - x[i];
        // The Hermite tangents of spline_weights (times the width), integrated exactly: the
        // segment's integral is width * ((f0 + f1) / 2 + (d0 - d1) / 12).
        const double d0 =
            i > 0 ? width * (f[i + 1] - f[i - 1]) / (x[i + 1] - x[i - 1]) : f[i + 1] - f[i];
        const double d1 =
            i + 2 < n ? width * (f[i + 2] - f[i]) / (x[i + 2] - x[i]) : f[i + 1] - f[i];
        if (width > 0.0) sum += ((d0 - d1) / 12.0 + (f[i] + f[i + 1]) * 0.5) * width;
        cdf[i + 1] = sum;
    }
    return sum;
}

FourierBsdf make_fourier_bsdf(std::span<const double> mu, int orders, const FourierSeriesSource& b,
                              const FourierBuildOptions& options) {
    if (orders < 1)
        throw InputError(cat("make_fourier_bsdf: orders must be >= 1 (got ", orders, ")"));
    if (options.channels != 1 && options.channels != 3)
        throw InputError(
            cat("make_fourier_bsdf: channels must be 1 or 3 (got ", options.channels, ")"));
    if (!(options.truncation >= 0.0) || !std::isfinite(options.truncation))
        throw InputError(cat("make_fourier_bsdf: truncation must be >= 0 (got ",
                             detail::value_text(options.truncation), ")"));
    if (!(options.eta > 0.0f) || !std::isfinite(options.eta))
        throw InputError(
            cat("make_fourier_bsdf: eta must be > 0 (got ", detail::value_text(options.eta), ")"));
    if (mu.empty()) throw InputError("make_fourier_bsdf: no nodes");
    // The file holds float32 nodes; b is evaluated at exactly those.
    std::vector<double> positive;
    for (std::size_t k = 0; k < mu.size(); ++k) {
        const float m = static_cast<float>(mu[k]);
        if (!(m > 0.0f && m <= 1.0f))
            throw InputError(cat("make_fourier_bsdf: mu[", k, "] = ", detail::value_text(mu[k]),
                                 " is not in (0, 1]"));
        if (!positive.empty() && !(m > positive.back()))
            throw InputError(cat("make_fourier_bsdf: mu[", k, "] = ", mu[k], " is not above mu[",
                                 k - 1, "] = ", mu[k - 1],
                                 " in float32 (nodes ascending, distinct)"));
        positive.push_back(m);
    }
    if (positive.back() != 1.0) positive.push_back(1.0);

    // Nodes: -1 .. -mu_1, -0, +0, mu_1 .. 1 (layerlab's storage.cpp: fromLayerGeneral).
    const std::size_t np = positive.size(), n = 2 * (np + 1);
    const std::size_t minus_zero = np, plus_zero = np + 1;
    FourierBsdf out;
    out.channels = options.channels;
    out.eta = options.eta;
    out.mu.resize(n);
    for (std::size_t k = 0; k < np; ++k) {
        out.mu[k] = static_cast<float>(-positive[np - 1 - k]);
        out.mu[plus_zero + 1 + k] = static_cast<float>(positive[k]);
    }
    out.mu[minus_zero] = out.mu[plus_zero] = 0.0f;
    out.series.resize(n * n);

    const std::size_t m_count = static_cast<std::size_t>(orders);
    std::vector<double> source(3 * m_count);
    std::array<std::vector<double>, 3> stored; // Y, R, B (or Y) of one pair, our signs fixed
    for (auto& s : stored) s.resize(m_count);
    const auto kept_length = [&](const std::vector<double>& a) {
        std::size_t length = m_count;
        double tail = 0.0;
        for (std::size_t k = m_count - 1; k >= 1; --k) {
            tail += std::abs(a[k]);
            if (tail <= options.truncation * std::abs(a[0]))
                length = k;
            else
                break;
        }
        if (length == 1 && a[0] == 0.0) length = 0;
        return length;
    };
    for (std::size_t o = 0; o < n; ++o)
        for (std::size_t i = 0; i < n; ++i) {
            FourierBsdf::Series& s = out.series[o * n + i];
            s.offset = static_cast<std::uint32_t>(std::min<std::size_t>(
                out.coefficients.size(), std::numeric_limits<std::uint32_t>::max()));
            // Reflection from above only: light above (mu_i <= -0), viewer above (mu_o >= +0).
            // The row mu_i = -0 is zero: a_k carries the factor |mu_i|.
            if (!(o >= plus_zero && i < minus_zero)) continue;
            const double mu_light = -static_cast<double>(out.mu[i]);
            const double mu_view = o == plus_zero ? 0.0 : static_cast<double>(out.mu[o]);
            std::fill(source.begin(), source.end(), 0.0);
            b(mu_light, mu_view, source);
            for (std::size_t k = 0; k < source.size(); ++k)
                if (!std::isfinite(source[k]))
                    throw NumericalError(cat(
                        "make_fourier_bsdf: non-finite coefficient ", detail::value_text(source[k]),
                        " of order ", k % m_count, " in the ", channel_name(int(k / m_count)),
                        " channel at mu_i ", mu_light, ", mu_o ", mu_view));
            // Our phi = pi - phi' makes cos(m phi) = (-1)^m cos(m phi'); and pbrt-v3 stores
            // f |mu_i| (PBR eq. 8.21).
            for (std::size_t k = 0; k < m_count; ++k) {
                const double sign_mu = (k % 2 == 0 ? 1.0 : -1.0) * mu_light;
                const double r = sign_mu * source[k], g = sign_mu * source[m_count + k],
                             bl = sign_mu * source[2 * m_count + k];
                stored[0][k] = fourier_luminance_weights[0] * r + fourier_luminance_weights[1] * g +
                               fourier_luminance_weights[2] * bl;
                stored[1][k] = r;
                stored[2][k] = bl;
            }
            std::size_t length = 0;
            for (int c = 0; c < options.channels; ++c)
                length = std::max(length, kept_length(stored[c]));
            if (length == 0) continue;
            const std::size_t end =
                out.coefficients.size() + length * std::size_t(options.channels);
            if (end > std::size_t(std::numeric_limits<std::int32_t>::max()))
                throw LimitError(cat("make_fourier_bsdf: more than 2^31 - 1 coefficients (", n,
                                     " nodes, ", orders, " orders): pbrt-v3 counts them in int32"));
            s.length = static_cast<std::uint32_t>(length);
            out.max_order = std::max(out.max_order, s.length);
            for (int c = 0; c < options.channels; ++c)
                for (std::size_t k = 0; k < length; ++k)
                    out.coefficients.push_back(static_cast<float>(stored[c][k]));
        }

    // pbrt-v3 samples mu_i from the row of a_0 (Y) at each mu_o.
    out.cdf.resize(n * n);
    std::vector<double> x(n), f(n), cdf(n);
    for (std::size_t k = 0; k < n; ++k) x[k] = out.mu[k];
    for (std::size_t o = 0; o < n; ++o) {
        for (std::size_t i = 0; i < n; ++i) {
            const FourierBsdf::Series& s = out.series[o * n + i];
            f[i] = s.length > 0 ? static_cast<double>(out.coefficients[s.offset]) : 0.0;
        }
        integrate_catmull_rom(x, f, cdf);
        for (std::size_t i = 0; i < n; ++i) out.cdf[o * n + i] = static_cast<float>(cdf[i]);
    }
    out.metadata = fourier_provenance_metadata(options.spec, options.generator, options.colorspace);
    return out;
}

} // namespace brdf::formats
