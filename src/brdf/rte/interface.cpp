#include <brdf/rte/interface.h>

#include <algorithm>
#include <cmath>

namespace brdf::rte {

double Interface::inside(double mu_air) const {
    const double sin2 = (1.0 - mu_air * mu_air) / (n * n);
    return std::sqrt(std::max(0.0, 1.0 - sin2));
}

double Interface::outside(double mu_inside) const {
    const double sin2 = n * n * (1.0 - mu_inside * mu_inside);
    return sin2 >= 1.0 ? 0.0 : std::sqrt(1.0 - sin2);
}

double Interface::critical() const { return n > 1.0 ? std::sqrt(1.0 - 1.0 / (n * n)) : 0.0; }

double Interface::reflectance_from_air(double mu_air) const {
    const double mu_t = inside(mu_air);
    const double rs = (mu_air - n * mu_t) / (mu_air + n * mu_t);
    const double rp = (n * mu_air - mu_t) / (n * mu_air + mu_t);
    return 0.5 * (rs * rs + rp * rp);
}

double Interface::reflectance_from_inside(double mu_inside) const {
    if (mu_inside <= critical()) return 1.0;
    return reflectance_from_air(outside(mu_inside));
}

} // namespace brdf::rte
