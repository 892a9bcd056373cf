#pragma once
// The 15-point Gauss-Kronrod rule on [-1, 1] and its embedded 7-point Gauss rule: QUADPACK's qk15
// (Piessens, de Doncker-Kapenga, Ueberhuber and Kahaner 1983, "QUADPACK", Springer). Nodes are
// +-kronrod_x[i]; the Gauss nodes are kronrod_x[1], [3], [5], [7] with weights gauss_w.
// tests/mie/ensemble_test.cpp checks that the Kronrod rule integrates x^k exactly for k <= 22 and the
// Gauss rule for k <= 13, and that the Gauss nodes are gauss_legendre(7)'s.

namespace brdf::mie::detail {

inline constexpr double kronrod_x[8] = {0.991455371120812639206854697526329,
                                        0.949107912342758524526189684047851,
                                        0.864864423359769072789712788640926,
                                        0.741531185599394439863864773280788,
                                        0.586087235467691130294144845693013,
                                        0.405845151377397166906606412076961,
                                        0.207784955007898467600689403773245,
                                        0.000000000000000000000000000000000};
inline constexpr double kronrod_w[8] = {0.022935322010529224963732008058970,
                                        0.063092092629978553290700663189204,
                                        0.104790010322250183839876322541518,
                                        0.140653259715525918745189590510238,
                                        0.169004726639267902826583426598550,
                                        0.190350578064785409913256402421014,
                                        0.204432940075298892414161999234649,
                                        0.209482141084727828012999174891714};
inline constexpr double gauss_w[4] = {0.129484966168869693270611432679082,
                                      0.279705391489276667901467771423780,
                                      0.381830050505118944950369775488975,
                                      0.417959183673469387755102040816327};

} // namespace brdf::mie::detail
