#include <brdf/preview/preview.h>

#include <brdf/core/threads.h>
#include <brdf/model/table_fill.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <numbers>
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
            const double a = r->lobe_albedo(mu, 1e-4);
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

// The Fourier grid of the body's interpolant for a tabulated render. The render samples the body
// on cell-centred zenith angles 90 / theta_nodes degrees apart (3.75 at the default 24) and
// interpolates trilinearly: preview_zenith_grid (about 2 degrees apart) is finer than that. A finer
// render grid, or a render that evaluates the body at every sample (theta_nodes 0), keeps the
// table's grid.
int body_grid(const RenderOptions& options) {
    return options.theta_nodes > 0 && options.theta_nodes <= 24 ? preview_zenith_grid : 0;
}

} // namespace

Image render_material(const model::SolvedMaterial& material, RenderOptions options) {
    // The material's values are in its spec's colour space; the preview is shaded in Rec.709.
    const material::ColorSpace space = material.spec.colorspace;
    switch (material.spec.surface.kind) {
    case material::Surface::Smooth: {
        // The mirror reflectance is smooth in theta: tabulated once (one solve per sample for all
        // the nodes) and interpolated linearly, instead of solved at every sub-pixel sample.
        constexpr int nodes = 1025;
        std::vector<double> thetas(nodes);
        for (int k = 0; k < nodes; ++k) thetas[k] = 0.5 * std::numbers::pi * k / (nodes - 1);
        auto table = std::make_shared<std::vector<model::Rgb>>(material.mirror(thetas));
        options.mirror = in_rec709(
            [table](double theta) {
                const double t = std::clamp(theta / (0.5 * std::numbers::pi), 0.0, 1.0) * (nodes - 1);
                const int k = std::min(static_cast<int>(t), nodes - 2);
                const double w = t - k;
                model::Rgb out;
                for (int c = 0; c < 3; ++c) out[c] = (1.0 - w) * (*table)[k][c] + w * (*table)[k + 1][c];
                return out;
            },
            space);
        break;
    }
    case material::Surface::Rough: {
        // The lobe exactly (render.h); the body as the table fill has it (its orders on the fill's
        // zenith grid, computed once: SolvedMaterial::brdf would recompute the rough interface's
        // kernels at every one of the render grid's thousands of directions).
        // The lobe is the fill's too: one closed form per direction with the channels' Fresnel
        // factors tabulated, instead of one per sample.
        auto body = std::make_shared<model::FillInputs>(model::prepare_fill(material, body_grid(options)));
        auto lobe = std::make_shared<model::FillInputs>();
        lobe->grid = 2; // no orders: the lobe alone
        lobe->lobe = body->lobe;
        lobe->lobe_separable = body->lobe_separable;
        lobe->lobe_alpha = body->lobe_alpha;
        lobe->lobe_points = body->lobe_points;
        lobe->lobe_fresnel = body->lobe_fresnel;
        body->lobe = model::FillInputs::Lobe::None;
        options.lobe = in_rec709(
            [lobe](double mu_i, double mu_o, double cos_phi) { return model::fill_value_from_cosines(*lobe, mu_i, mu_o, cos_phi); },
            space);
        options.lobe_albedo = in_rec709(lobe_albedo(material), space);
        return render_sphere(
            in_rec709([body](double ti, double to, double phi) { return model::fill_value(*body, ti, to, phi); }, space),
            options);
    }
    case material::Surface::None: break;
    }
    // The body through the table fill's batched data (microseconds per direction, where
    // SolvedMaterial::brdf solves a Nystrom system per direction and wavelength); the dipole
    // comparison model is not in the fill and keeps the per-direction path.
    if (material.spec.model == material::Model::Dipole)
        return render_sphere(
            in_rec709([&material](double ti, double to, double phi) { return material.brdf(ti, to, phi); }, space),
            options);
    auto fill = std::make_shared<model::FillInputs>(model::prepare_fill(material, body_grid(options)));
    return render_sphere(
        in_rec709([fill](double ti, double to, double phi) { return model::fill_value(*fill, ti, to, phi); }, space),
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
