#include <brdf/core/lane_set.h>

#include <cstdlib>
#include <string_view>

namespace brdf {

LaneSet lane_set() {
    static const LaneSet set = [] {
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
        const char* wanted = std::getenv("BRDF_LANES");
        const std::string_view name = wanted ? wanted : "";
        if (name == "baseline") return LaneSet::baseline;
        if (__builtin_cpu_supports("avx512f") && name != "avx2") return LaneSet::avx512;
        if (__builtin_cpu_supports("avx2")) return LaneSet::avx2;
#endif
        return LaneSet::baseline;
    }();
    return set;
}

} // namespace brdf
