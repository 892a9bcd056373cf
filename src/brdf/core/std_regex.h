#pragma once
// <regex> for code built with GCC 12's sanitizers too (CI's build-asan), where GCC warns inside
// libstdc++'s regex automaton that a moved std::function "may be used uninitialized": a false
// positive in the library's own code, off for the header's templates alone.

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <regex>
#pragma GCC diagnostic pop
