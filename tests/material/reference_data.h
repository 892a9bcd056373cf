#pragma once
// Reading the checked-in reference tables of tests/reference/material (written by the Python
// scripts beside them; the tests never run Python).

#include "test_support.h"

#include <sstream>
#include <string>
#include <vector>

namespace brdf::test {

/// The rows of a reference CSV as strings: '#' lines and the header line skipped.
inline std::vector<std::vector<std::string>> read_reference_csv(const std::string& name) {
    const std::string text = read_file(source_dir() / "tests" / "reference" / "material" / name);
    std::vector<std::vector<std::string>> rows;
    std::istringstream in(text);
    std::string line;
    bool header = false;
    while (std::getline(in, line)) {
        if (line.empty() || line.front() == '#') continue;
        if (!header) {
            header = true;
            continue;
        }
        std::vector<std::string> fields;
        std::istringstream fs(line);
        std::string field;
        while (std::getline(fs, field, ',')) fields.push_back(field);
        rows.push_back(fields);
    }
    return rows;
}

/// "key v1 v2 ..." lines of spectral_summary.txt: the numbers after `key`.
inline std::vector<double> read_summary_values(const std::string& key) {
    const std::string text =
        read_file(source_dir() / "tests" / "reference" / "material" / "spectral_summary.txt");
    std::istringstream in(text);
    std::string line;
    while (std::getline(in, line)) {
        std::istringstream ls(line);
        std::string first;
        ls >> first;
        if (first != key) continue;
        std::vector<double> values;
        double v = 0.0;
        while (ls >> v) values.push_back(v);
        return values;
    }
    ADD_FAILURE() << "spectral_summary.txt has no line " << key;
    return {};
}

} // namespace brdf::test
