#include <brdf/preview/preview.h>

#include <brdf/core/threads.h>
#include <brdf/model/table_fill.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

namespace brdf::preview {

namespace {

// The lobe's directional albedo (RoughInterface::albedo_from_air, reflected part) on a grid in
// cos(theta), interpolated linearly: smooth in the cosine, and the environment term it weights is
// an approximation anyway.
MirrorFunction lobe_albedo(const model::SolvedMaterial& m) {
    constexpr int points = 33;
    auto table = std::make_shared<std::vector<Rgb>>(points, Rgb{0.0, 0.0, 0.0});
    parallel_for(points, available_cpus(), [&](int k) {
        const double mu = std::max(1e-3, static_cast<double>(k) / (points - 1));
        for (const model::WavelengthSolution& s : m.samples) {
            const rte::RoughInterface* r = s.reflection.rough_interface();
            if (!r) continue;
            const double a = r->albedo_from_air(mu, 1e-4).reflected;
            for (int c = 0; c < 3; ++c) (*table)[k][c] += s.weight[c] * a;
        }
    });
    return [table](double theta) {
        const double t = std::clamp(std::cos(theta), 0.0, 1.0) * (points - 1);
        const int k = std::min(static_cast<int>(t), points - 2);
        const double f = t - k;
        Rgb out;
        for (int c = 0; c < 3; ++c) out[c] = (1.0 - f) * (*table)[k][c] + f * (*table)[k + 1][c];
        return out;
    };
}

} // namespace

Image render_material(const model::SolvedMaterial& material, RenderOptions options) {
    switch (material.spec.surface.kind) {
    case material::Surface::Smooth:
        options.mirror = [&material](double theta) { return material.mirror(theta); };
        break;
    case material::Surface::Rough: {
        // The lobe exactly (render.h); the body as the table fill has it (its orders on the fill's
        // zenith grid, computed once: SolvedMaterial::brdf would recompute the rough interface's
        // kernels at every one of the render grid's thousands of directions).
        // The lobe is the fill's too: one closed form per direction with the channels' Fresnel
        // factors tabulated, instead of one per sample.
        auto body = std::make_shared<model::FillInputs>(model::prepare_fill(material));
        auto lobe = std::make_shared<model::FillInputs>();
        lobe->grid = 2; // no orders: the lobe alone
        lobe->lobe = body->lobe;
        lobe->lobe_separable = body->lobe_separable;
        lobe->lobe_alpha = body->lobe_alpha;
        lobe->lobe_points = body->lobe_points;
        lobe->lobe_fresnel = body->lobe_fresnel;
        body->lobe = model::FillInputs::Lobe::None;
        options.lobe = [lobe](double ti, double to, double phi) { return model::fill_value(*lobe, ti, to, phi); };
        options.lobe_albedo = lobe_albedo(material);
        return render_sphere([body](double ti, double to, double phi) { return model::fill_value(*body, ti, to, phi); },
                             options);
    }
    case material::Surface::None: break;
    }
    return render_sphere([&material](double ti, double to, double phi) { return material.brdf(ti, to, phi); },
                         options);
}

void write_preview(const model::SolvedMaterial& material, const std::filesystem::path& png) {
    output_format(png); // a bad extension fails before the rendering
    RenderOptions options;
    options.size = 256;
    options.environment = Environment::Sky;
    options.environment_radiance = 0.3;
    write_image(render_material(material, options), png);
}

} // namespace brdf::preview
