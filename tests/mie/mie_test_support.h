#pragma once
// Helpers shared by the Mie tests: the checked-in reference values and error-message checks.

#include "test_support.h"

#include <nlohmann/json.hpp>

#include <fstream>
#include <functional>
#include <string>

namespace brdf::test {

/// tests/reference/mie/mie_reference.json, produced by mie_reference.py beside it. Loaded once.
inline const nlohmann::json& mie_reference() {
    static const nlohmann::json data = [] {
        const auto path = source_dir() / "tests/reference/mie/mie_reference.json";
        std::ifstream in(path);
        if (!in) throw std::runtime_error("cannot read " + path.string());
        return nlohmann::json::parse(in);
    }();
    return data;
}

/// Expects `f` to throw E whose message contains `needle`.
template <typename E>
void expect_error_mentions(const std::function<void()>& f, const std::string& needle) {
    try {
        f();
        ADD_FAILURE() << "no exception; expected one mentioning '" << needle << "'";
    } catch (const E& e) {
        EXPECT_NE(std::string(e.what()).find(needle), std::string::npos)
            << "message '" << e.what() << "' does not mention '" << needle << "'";
    } catch (const std::exception& e) {
        ADD_FAILURE() << "wrong exception type: " << e.what();
    }
}

} // namespace brdf::test
