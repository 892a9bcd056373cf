#include <brdf/preview/preview.h>

namespace brdf::preview {

Image render_material(const model::SolvedMaterial& material, RenderOptions options) {
    if (material.spec.surface.kind == material::Surface::Smooth)
        options.mirror = [&material](double theta) { return material.mirror(theta); };
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
