#pragma once
// LeakSanitizer's leak check at the end of main, in sanitized builds (-DBRDF_SANITIZE=address).
//
// By default LeakSanitizer checks from an exit handler, after the static destructors have run,
// and it stops every thread with ptrace to read their stacks. By then releasing the OpenCL
// context has told PoCL's device threads to wind down, and a thread that exits while the tracer
// holds it now and then crashes the tracer itself ("Tracer caught signal 11 ... LeakSanitizer has
// encountered a fatal error", google/sanitizers#1353): the process then fails with no leak found.
// Checking on the way out of main, while every thread is still parked, finds the same leaks
// (what the statics hold is reachable either way) and turns the exit-time check off.

#if defined(__SANITIZE_ADDRESS__)
#include <sanitizer/lsan_interface.h>
#endif

namespace brdf::tool {

/// The status main returns, after the leak check in a sanitized build (which exits non-zero
/// itself when it finds a leak); a no-op otherwise.
inline int after_leak_check(int status) {
#if defined(__SANITIZE_ADDRESS__)
    __lsan_do_leak_check();
#endif
    return status;
}

} // namespace brdf::tool
