#pragma once
// The smooth air/binder interface (docs/physics.md section 4): Snell refraction, unpolarised Fresnel
// reflectance (Born and Wolf, Principles of Optics, section 1.5), total internal reflection.

namespace brdf::rte {

/// Binder index n >= 1 seen from air. n == 1 means no interface.
struct Interface {
    double n = 1.0;
    bool present() const { return n != 1.0; }
    /// Cosine inside the binder of a ray with cosine mu_air in air.
    double inside(double mu_air) const;
    /// Cosine in air of a ray with cosine mu_inside in the binder; 0 when it is totally reflected.
    double outside(double mu_inside) const;
    /// Critical cosine inside: rays with mu_inside < critical() are totally reflected.
    double critical() const;
    /// Fresnel reflectance for light arriving from air at cosine mu_air (equal, by reciprocity, to
    /// the reflectance inside at the refracted cosine).
    double reflectance_from_air(double mu_air) const;
    /// Reflectance for light arriving from inside at cosine mu_inside (1 beyond the critical angle).
    double reflectance_from_inside(double mu_inside) const;
};

} // namespace brdf::rte
