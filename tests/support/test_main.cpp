// main() of every gtest binary (cmake/BrdfTesting.cmake): GoogleTest's own, plus the sanitized
// builds' leak check while every thread is still parked (tools/common/leak_check.h says why).

#include <leak_check.h>

#include <gtest/gtest.h>

int main(int argc, char** argv) {
    testing::InitGoogleTest(&argc, argv);
    return brdf::tool::after_leak_check(RUN_ALL_TESTS());
}
