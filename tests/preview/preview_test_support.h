#pragma once
// Helpers shared by the preview tests: simple BRDFs, solved analytic media, reading images back with
// OpenImageIO, and region means of an image.

#include <brdf/core/error.h>
#include <brdf/material/spec.h>
#include <brdf/preview/image.h>
#include <brdf/preview/render.h>
#include <brdf/model/model.h>

#include <OpenImageIO/imageio.h>

#include <gtest/gtest.h>

#include <filesystem>
#include <numbers>
#include <string>

namespace brdf::test {

/// A white Lambertian surface: 1/pi everywhere.
inline preview::BrdfFunction lambertian(double albedo = 1.0) {
    return [albedo](double, double, double) {
        const double v = albedo / std::numbers::pi;
        return preview::Rgb{v, v, v};
    };
}

/// Solves one analytic-medium spec (JSON text) on the CPU.
inline model::SolvedMaterial solve_text(const std::string& json) {
    const auto specs = material::parse_specs_text(json, "test spec");
    return model::solve_material(specs.at(0), model::Device::Cpu);
}

struct ReadImage {
    int width = 0, height = 0, channels = 0;
    OIIO::TypeDesc format;
    std::vector<float> pixels; ///< as stored, converted to float (8-bit: 0..1)
    float at(int x, int y, int c) const { return pixels[(static_cast<std::size_t>(y) * width + x) * channels + c]; }
};

inline ReadImage read_image(const std::filesystem::path& path) {
    ReadImage out;
    auto in = OIIO::ImageInput::open(path.string());
    if (!in) {
        ADD_FAILURE() << path << ": OpenImageIO cannot open it: " << OIIO::geterror();
        return out;
    }
    const OIIO::ImageSpec& spec = in->spec();
    out.width = spec.width;
    out.height = spec.height;
    out.channels = spec.nchannels;
    out.format = spec.format;
    out.pixels.resize(static_cast<std::size_t>(out.width) * out.height * out.channels);
    EXPECT_TRUE(in->read_image(0, 0, 0, out.channels, OIIO::TypeDesc::FLOAT, out.pixels.data())) << in->geterror();
    in->close();
    return out;
}

/// Mean over channels and pixels of columns [x0, x1) (all rows) of a preview image.
inline double column_mean(const preview::Image& image, int x0, int x1) {
    double sum = 0.0;
    for (int y = 0; y < image.height; ++y)
        for (int x = x0; x < x1; ++x)
            for (int c = 0; c < 3; ++c) sum += image.at(x, y)[c];
    return sum / (3.0 * image.height * (x1 - x0));
}

inline double column_mean(const ReadImage& image, int x0, int x1) {
    double sum = 0.0;
    for (int y = 0; y < image.height; ++y)
        for (int x = x0; x < x1; ++x)
            for (int c = 0; c < 3; ++c) sum += image.at(x, y, c);
    return sum / (3.0 * image.height * (x1 - x0));
}

} // namespace brdf::test
