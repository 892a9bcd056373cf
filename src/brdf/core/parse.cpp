#include <brdf/core/parse.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <charconv>
#include <cmath>
#include <system_error>

namespace brdf {
namespace {

// std::from_chars is locale-independent and reports exactly how much it consumed, which makes the
// "whole text or nothing" rule easy to enforce. It does not take a leading '+', so that is skipped
// here (users write "+1e-3" in indices and expect it to work).
bool parse_finite(std::string_view text, double& value) {
    if (!text.empty() && text.front() == '+') {
        text.remove_prefix(1);
        if (!text.empty() && (text.front() == '+' || text.front() == '-')) return false; // "+-1"
    }
    if (text.empty()) return false;
    const char* last = text.data() + text.size();
    const auto [end, ec] = std::from_chars(text.data(), last, value);
    // from_chars accepts "nan" and "inf"; neither is a usable physical value.
    return ec == std::errc() && end == last && std::isfinite(value);
}

} // namespace

double parse_double(std::string_view text, std::string_view what) {
    if (text.empty()) throw InputError(cat(what, ": expected a number, got an empty string"));
    double value = 0.0;
    if (!parse_finite(text, value))
        throw InputError(cat(what, ": expected a finite number, got '", text, "'"));
    return value;
}

std::complex<double> parse_complex_index(std::string_view text, std::string_view what) {
    const auto bad_format = [&] {
        return InputError(cat(what, ": expected a refractive index like 1.5 or 2.7+0.01i, got '",
                              text, "'"));
    };
    if (text.empty()) throw InputError(cat(what, ": expected a refractive index, got an empty string"));
    double re = 0.0, im = 0.0;
    const char tail = text.back();
    if (tail == 'i' || tail == 'j') {
        // The sign that separates the parts is the last '+' or '-' that is neither the first
        // character nor an exponent sign ("2.7+1e-3i" splits at the '+', not at "e-").
        const std::string_view body = text.substr(0, text.size() - 1);
        std::size_t split = std::string_view::npos;
        for (std::size_t i = body.size(); i-- > 1;) {
            if ((body[i] == '+' || body[i] == '-') && body[i - 1] != 'e' && body[i - 1] != 'E') {
                split = i;
                break;
            }
        }
        if (split == std::string_view::npos) throw bad_format();
        if (!parse_finite(body.substr(0, split), re) || !parse_finite(body.substr(split), im))
            throw bad_format();
    } else if (!parse_finite(text, re)) {
        throw bad_format();
    }
    if (im < 0.0)
        throw InputError(cat(what, ": imaginary part of '", text,
                             "' is negative; the convention is m = n + ik with absorption k >= 0 "
                             "(write ",
                             re, "+", -im, "i)"));
    if (!(re > 0.0))
        throw InputError(cat(what, ": real part of '", text, "' must be > 0"));
    return {re, im == 0.0 ? 0.0 : im}; // folds -0 into +0
}

} // namespace brdf
