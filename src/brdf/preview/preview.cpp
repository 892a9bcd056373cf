#include <brdf/preview/preview.h>

namespace brdf::preview {

Image render_material(const model::SolvedMaterial& material, RenderOptions options) {
    // The material's values are in its spec's colour space; the preview is shaded in Rec.709.
    const material::ColorSpace space = material.spec.colorspace;
    if (material.spec.surface.kind == material::Surface::Smooth)
        options.mirror = in_rec709([&material](double theta) { return material.mirror(theta); }, space);
    return render_sphere(
        in_rec709([&material](double ti, double to, double phi) { return material.brdf(ti, to, phi); }, space),
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
