#include <brdf/material/refractive_index.h>

#include <brdf/core/error.h>
#include <brdf/core/log.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <limits>
#include <optional>

namespace brdf::material {

// ---------------------------------------------------------------------------------------------
// Small helpers

bool WavelengthRange::contains(double wavelength_nm) const {
    const double slack = 1e-9 * std::max(std::abs(min_nm), std::abs(max_nm));
    return wavelength_nm >= min_nm - slack && wavelength_nm <= max_nm + slack;
}

std::string_view to_string(DataType type) {
    switch (type) {
    case DataType::Formula1:
        return "formula 1";
    case DataType::Formula2:
        return "formula 2";
    case DataType::Formula4:
        return "formula 4";
    case DataType::TabulatedNK:
        return "tabulated nk";
    case DataType::TabulatedN:
        return "tabulated n";
    case DataType::TabulatedK:
        return "tabulated k";
    }
    return "unknown";
}

bool is_formula(DataType type) {
    return type == DataType::Formula1 || type == DataType::Formula2 || type == DataType::Formula4;
}

namespace {

std::string join(const std::vector<std::string>& parts, std::string_view separator) {
    std::string out;
    for (std::size_t i = 0; i < parts.size(); ++i) {
        if (i) out += separator;
        out += parts[i];
    }
    return out;
}

std::string range_text(const WavelengthRange& r) {
    return cat(r.min_nm, "-", r.max_nm, " nm");
}

// ---------------------------------------------------------------------------------------------
// The YAML subset reader

struct Line {
    int number = 0;        // 1-based
    int indent = 0;        // leading spaces
    std::string_view text; // after the indentation, trailing white space removed
};

bool is_space(char c) {
    return c == ' ' || c == '\t';
}

std::string_view trim(std::string_view s) {
    while (!s.empty() && (is_space(s.front()) || s.front() == '\r')) s.remove_prefix(1);
    while (!s.empty() && (is_space(s.back()) || s.back() == '\r')) s.remove_suffix(1);
    return s;
}

std::vector<std::string_view> split_words(std::string_view s) {
    std::vector<std::string_view> words;
    std::size_t i = 0;
    while (i < s.size()) {
        while (i < s.size() && is_space(s[i])) ++i;
        const std::size_t start = i;
        while (i < s.size() && !is_space(s[i])) ++i;
        if (i > start) words.push_back(s.substr(start, i - start));
    }
    return words;
}

std::optional<DataType> parse_type(std::string_view s) {
    if (s == "formula 1") return DataType::Formula1;
    if (s == "formula 2") return DataType::Formula2;
    if (s == "formula 4") return DataType::Formula4;
    if (s == "tabulated nk") return DataType::TabulatedNK;
    if (s == "tabulated n") return DataType::TabulatedN;
    if (s == "tabulated k") return DataType::TabulatedK;
    return std::nullopt;
}

class Reader {
  public:
    Reader(std::string_view text, std::string_view name, const ReadOptions& options)
        : m_name(name), m_options(options) {
        split(text);
    }

    IndexFile read() {
        IndexFile file;
        file.name = std::string(m_name);
        bool seen_references = false, seen_comments = false, seen_data = false;
        while (m_pos < m_lines.size()) {
            const Line line = m_lines[m_pos];
            if (skippable(line)) {
                ++m_pos;
                continue;
            }
            if (line.indent != 0)
                fail(line.number,
                     "unexpected indentation (expected a top-level key such as DATA:)");
            const std::pair<std::string_view, std::string_view> kv = split_key(line, line.text);
            const std::string_view key = kv.first, value = kv.second;
            auto once = [&](bool& seen) {
                if (seen) fail(line.number, cat("duplicate key ", key));
                seen = true;
            };
            if (key == "REFERENCES") {
                once(seen_references);
                file.references = scalar_text(value, line);
            } else if (key == "COMMENTS") {
                once(seen_comments);
                file.comments = scalar_text(value, line);
            } else if (key == "DATA") {
                once(seen_data);
                if (!value.empty())
                    fail(line.number, "DATA: expected its entries on the following lines");
                ++m_pos;
                read_data_list(line, file);
            } else if (key == "CONDITIONS" || key == "SPECS" || key == "PROPERTIES") {
                // Measurement conditions and specifications (temperature, direction, ...): not
                // used.
                ++m_pos;
                skip_nested(line.indent);
            } else {
                fail(line.number, cat("unknown key '", key,
                                      "' (expected REFERENCES, COMMENTS, DATA, CONDITIONS, SPECS "
                                      "or PROPERTIES)"));
            }
        }
        if (!seen_data) fail(static_cast<int>(m_lines.size()), "no DATA in the file");
        file.repairs = std::move(m_repairs);
        return file;
    }

  private:
    [[noreturn]] void fail(int line, const std::string& message) const {
        throw FormatError(cat(m_name, ":", line, ": ", message));
    }

    void split(std::string_view text) {
        int number = 0;
        std::size_t start = 0;
        while (start <= text.size()) {
            std::size_t end = text.find('\n', start);
            if (end == std::string_view::npos) end = text.size();
            std::string_view raw = text.substr(start, end - start);
            ++number;
            if (!raw.empty() && raw.back() == '\r') raw.remove_suffix(1);
            Line line;
            line.number = number;
            std::size_t i = 0;
            while (i < raw.size() && is_space(raw[i])) {
                // YAML forbids tabs in indentation; a tab would also make our columns wrong.
                if (raw[i] == '\t') fail(number, "tab character in indentation (use spaces)");
                ++i;
            }
            line.indent = static_cast<int>(i);
            line.text = trim(raw.substr(i));
            m_lines.push_back(line);
            if (end == text.size()) break;
            start = end + 1;
        }
    }

    static bool skippable(const Line& line) {
        return line.text.empty() || line.text.front() == '#';
    }

    // "key: value" -> (key, value); the key is a plain word.
    std::pair<std::string_view, std::string_view> split_key(const Line& line,
                                                            std::string_view text) const {
        const std::size_t colon = text.find(':');
        if (colon == std::string_view::npos || colon == 0)
            fail(line.number, cat("expected 'key: value', got '", text, "'"));
        const std::string_view key = text.substr(0, colon);
        for (char c : key)
            if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_'))
                fail(line.number, cat("expected 'key: value', got '", text, "'"));
        const std::string_view value = trim(text.substr(colon + 1));
        if (colon + 1 < text.size() && !is_space(text[colon + 1]))
            fail(line.number, cat("expected a space after '", key, ":'"));
        return {key, value};
    }

    // Skips every line more indented than `parent` (and blank or comment lines).
    void skip_nested(int parent) {
        while (m_pos < m_lines.size() &&
               (skippable(m_lines[m_pos]) || m_lines[m_pos].indent > parent))
            ++m_pos;
    }

    // The content lines of a block scalar "|" that follows the key on `key_line`: every following
    // line more indented than the key, or blank. m_pos is advanced past them.
    std::vector<Line> block_lines(const Line& key_line, int key_indent) {
        std::vector<Line> lines;
        ++m_pos;
        while (m_pos < m_lines.size()) {
            const Line& l = m_lines[m_pos];
            if (!l.text.empty() && l.indent <= key_indent) break;
            lines.push_back(l);
            ++m_pos;
        }
        while (!lines.empty() && lines.back().text.empty()) lines.pop_back();
        if (lines.empty()) fail(key_line.number, "empty block after '|'");
        return lines;
    }

    // A scalar value: a block "|" on the following lines, or the plain text after the colon.
    std::string scalar_text(std::string_view value, const Line& key_line) {
        if (value == "|" || value == "|-") {
            const std::vector<Line> lines = block_lines(key_line, key_line.indent);
            std::string text;
            for (const Line& l : lines) {
                if (!text.empty()) text += '\n';
                text += l.text;
            }
            return text;
        }
        ++m_pos;
        return std::string(value);
    }

    struct RawEntry {
        int line = 0;
        std::optional<DataType> type;
        std::optional<WavelengthRange> range;
        int range_line = 0;
        std::optional<std::vector<double>> coefficients;
        int coefficients_line = 0;
        std::optional<std::vector<Line>> rows;
        int data_line = 0;
    };

    double number(std::string_view token, int line, std::string_view what) const {
        std::string_view t = token;
        if (!t.empty() && t.front() == '+') t.remove_prefix(1);
        double value = 0.0;
        const auto [end, ec] = std::from_chars(t.data(), t.data() + t.size(), value);
        if (t.empty() || ec != std::errc() || end != t.data() + t.size())
            fail(line, cat(what, ": '", token, "' is not a number"));
        if (!std::isfinite(value)) fail(line, cat(what, ": '", token, "' is not finite"));
        return value;
    }

    void read_data_list(const Line& data_line, IndexFile& file) {
        int list_indent = -1;
        while (m_pos < m_lines.size()) {
            const Line line = m_lines[m_pos];
            if (skippable(line)) {
                ++m_pos;
                continue;
            }
            const bool item = line.text.starts_with("- ") || line.text == "-";
            // The next top-level key (YAML also allows the list at the key's own indentation).
            if (line.indent == 0 && !item) break;
            if (!item) fail(line.number, "expected a DATA entry '- type: ...'");
            if (list_indent < 0) list_indent = line.indent;
            if (line.indent != list_indent)
                fail(line.number, "DATA entries must be indented alike");
            file.data.push_back(read_entry(line));
        }
        if (file.data.empty()) fail(data_line.number, "DATA has no entries");
    }

    DataEntry read_entry(const Line& item) {
        RawEntry raw;
        raw.line = item.number;
        std::string_view rest = item.text.substr(1);
        std::size_t skip = 1;
        while (!rest.empty() && rest.front() == ' ') {
            rest.remove_prefix(1);
            ++skip;
        }
        if (rest.empty()) fail(item.number, "empty DATA entry");
        const int key_indent = item.indent + static_cast<int>(skip);
        read_entry_key(item, rest, key_indent, raw);
        while (m_pos < m_lines.size()) {
            const Line line = m_lines[m_pos];
            if (skippable(line)) {
                ++m_pos;
                continue;
            }
            if (line.indent < key_indent) break; // the next entry or top-level key
            if (line.indent > key_indent)
                fail(line.number, "unexpected indentation in a DATA entry");
            read_entry_key(line, line.text, key_indent, raw);
        }
        return finish_entry(raw);
    }

    void read_entry_key(const Line& line, std::string_view text, int key_indent, RawEntry& raw) {
        const std::pair<std::string_view, std::string_view> kv = split_key(line, text);
        const std::string_view key = kv.first, value = kv.second;
        auto once = [&](bool seen) {
            if (seen) fail(line.number, cat("duplicate key ", key, " in a DATA entry"));
        };
        if (key == "type") {
            once(raw.type.has_value());
            raw.type = parse_type(value);
            if (!raw.type)
                fail(line.number, cat("unsupported data type '", value,
                                      "' (this reader knows formula 1, 2 and 4 and tabulated nk, "
                                      "n and k)"));
            ++m_pos;
        } else if (key == "wavelength_range") {
            once(raw.range.has_value());
            const auto words = split_words(value);
            if (words.size() != 2)
                fail(line.number,
                     cat("wavelength_range: expected two numbers (um), got '", value, "'"));
            const double lo = number(words[0], line.number, "wavelength_range");
            const double hi = number(words[1], line.number, "wavelength_range");
            if (!(lo > 0.0 && hi > lo))
                fail(line.number,
                     cat("wavelength_range: expected 0 < min < max, got '", value, "'"));
            raw.range = WavelengthRange{lo * 1000.0, hi * 1000.0};
            raw.range_line = line.number;
            ++m_pos;
        } else if (key == "coefficients") {
            once(raw.coefficients.has_value());
            std::vector<double> c;
            for (std::string_view w : split_words(value))
                c.push_back(number(w, line.number, "coefficients"));
            if (c.empty()) fail(line.number, "coefficients: no numbers");
            raw.coefficients = std::move(c);
            raw.coefficients_line = line.number;
            ++m_pos;
        } else if (key == "data") {
            once(raw.rows.has_value());
            if (value != "|")
                fail(line.number, "data: expected '|' and the rows on the next lines");
            raw.rows = block_lines(line, key_indent);
            raw.data_line = line.number;
        } else {
            fail(line.number, cat("unknown key '", key,
                                  "' in a DATA entry (expected type, wavelength_range, "
                                  "coefficients or data)"));
        }
    }

    DataEntry finish_entry(RawEntry& raw) {
        if (!raw.type) fail(raw.line, "DATA entry without 'type'");
        DataEntry entry;
        entry.type = *raw.type;
        entry.line = raw.line;
        const std::string_view type_name = to_string(entry.type);
        if (is_formula(entry.type)) {
            if (raw.rows) fail(raw.data_line, cat("'data' is not used with ", type_name));
            if (!raw.coefficients) fail(raw.line, cat(type_name, " without 'coefficients'"));
            if (!raw.range) fail(raw.line, cat(type_name, " without 'wavelength_range'"));
            const std::size_t count = raw.coefficients->size();
            if (entry.type == DataType::Formula4) {
                // C1, two resonance terms of four coefficients each, then power-term pairs.
                if (!(count == 1 || count == 5 || (count >= 9 && count <= 17 && count % 2 == 1)))
                    fail(raw.coefficients_line,
                         cat("formula 4 needs 1, 5, 9, 11, 13, 15 or 17 coefficients (got ", count,
                             ")"));
            } else if (count % 2 == 0) {
                fail(raw.coefficients_line,
                     cat(type_name, " needs C1 and pairs of coefficients, an odd count (got ",
                         count, ")"));
            }
            entry.coefficients = std::move(*raw.coefficients);
            entry.range = *raw.range;
            return entry;
        }
        if (raw.coefficients)
            fail(raw.coefficients_line, cat("'coefficients' is not used with ", type_name));
        if (raw.range)
            fail(raw.range_line, cat("'wavelength_range' is not used with ", type_name,
                                     " (the rows give the range)"));
        if (!raw.rows) fail(raw.line, cat(type_name, " without 'data'"));
        read_rows(*raw.rows, entry);
        return entry;
    }

    void read_rows(const std::vector<Line>& rows, DataEntry& entry) {
        const bool has_n = entry.gives_n(), has_k = entry.gives_k();
        const std::size_t columns = (has_n && has_k) ? 3 : 2;
        std::string_view previous_token;
        int negative_k_rows = 0, smallest_k_line = 0;
        double smallest_k = 0.0;
        for (const Line& row : rows) {
            if (row.text.empty()) continue;
            const auto words = split_words(row.text);
            if (words.size() != columns)
                fail(row.number, cat(to_string(entry.type), " row has ", words.size(),
                                     " fields, expected ", columns, ": '", row.text, "'"));
            const double wavelength_um = number(words[0], row.number, "wavelength");
            if (!(wavelength_um > 0.0))
                fail(row.number, cat("wavelength must be > 0 (got ", words[0], ")"));
            const double wavelength_nm = wavelength_um * 1000.0;
            if (!entry.wavelength_nm.empty() && !(wavelength_nm > entry.wavelength_nm.back())) {
                const std::string what =
                    cat("wavelength ", words[0], " um does not exceed the previous row's ",
                        previous_token, " um");
                if (!m_options.repair_tables)
                    fail(row.number, what + " (rows must be sorted by increasing wavelength)");
                m_repairs.push_back(cat(m_name, ":", row.number, ": ", what, ": row dropped"));
                continue;
            }
            double n = 0.0, k = 0.0;
            if (has_n) {
                n = number(words[1], row.number, "n");
                if (!(n > 0.0)) fail(row.number, cat("n must be > 0 (got ", words[1], ")"));
            }
            if (has_k) {
                const std::string_view token = words[columns - 1];
                k = number(token, row.number, "k");
                if (k < 0.0) {
                    if (!m_options.repair_tables)
                        fail(row.number, cat("k must be >= 0 (got ", token, ")"));
                    ++negative_k_rows;
                    if (k < smallest_k) {
                        smallest_k = k;
                        smallest_k_line = row.number;
                    }
                    k = 0.0;
                }
            }
            previous_token = words[0];
            entry.wavelength_nm.push_back(wavelength_nm);
            if (has_n) entry.n.push_back(n);
            if (has_k) entry.k.push_back(k);
        }
        if (negative_k_rows > 0)
            m_repairs.push_back(cat(m_name, ":", entry.line, ": ", negative_k_rows,
                                    negative_k_rows == 1 ? " row" : " rows",
                                    " with k < 0 (smallest ", smallest_k, " at line ",
                                    smallest_k_line, "): set to 0"));
        if (entry.wavelength_nm.size() < 2)
            fail(entry.line, cat(to_string(entry.type), " needs at least 2 rows (got ",
                                 entry.wavelength_nm.size(), ")"));
        entry.range = WavelengthRange{entry.wavelength_nm.front(), entry.wavelength_nm.back()};
    }

    std::string_view m_name;
    ReadOptions m_options;
    std::vector<Line> m_lines;
    std::size_t m_pos = 0;
    std::vector<std::string> m_repairs;
};

// Linear interpolation in x (strictly increasing); values beyond the ends are the end values (the
// caller has checked the range, up to WavelengthRange's rounding slack).
double interpolate(const std::vector<double>& x, const std::vector<double>& y, double xq) {
    if (xq <= x.front()) return y.front();
    if (xq >= x.back()) return y.back();
    const std::size_t i = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), xq) -
                                                   x.begin()); // x[i-1] <= xq < x[i]
    const double t = (xq - x[i - 1]) / (x[i] - x[i - 1]);
    return y[i - 1] + t * (y[i] - y[i - 1]);
}

double formula_n_squared(DataType type, std::span<const double> c, double um) {
    const double l2 = um * um;
    switch (type) {
    case DataType::Formula1:
    case DataType::Formula2: {
        double s = 1.0 + c[0];
        for (std::size_t i = 1; i + 1 < c.size(); i += 2) {
            const double pole = type == DataType::Formula1 ? c[i + 1] * c[i + 1] : c[i + 1];
            s += c[i] * l2 / (l2 - pole);
        }
        return s;
    }
    case DataType::Formula4: {
        // C(i) is the database's 1-based coefficient; missing ones are 0.
        auto C = [&](std::size_t i) { return i <= c.size() ? c[i - 1] : 0.0; };
        double s = C(1);
        for (std::size_t first : {std::size_t{2}, std::size_t{6}})
            if (C(first) != 0.0)
                s += C(first) * std::pow(um, C(first + 1)) /
                     (l2 - std::pow(C(first + 2), C(first + 3)));
        for (std::size_t i = 10; i + 1 <= c.size(); i += 2) s += C(i) * std::pow(um, C(i + 1));
        return s;
    }
    default:
        break;
    }
    throw FormatError(cat("formula_n: ", to_string(type), " is not a dispersion formula"));
}

} // namespace

IndexFile parse_index_file(std::string_view text, std::string_view name,
                           const ReadOptions& options) {
    if (text.size() > max_index_file_bytes)
        throw LimitError(cat(name, ": ", text.size(), " bytes exceed the limit of ",
                             max_index_file_bytes, " bytes for a refractive-index file"));
    return Reader(text, name, options).read();
}

double formula_n(DataType type, std::span<const double> coefficients, double wavelength_um) {
    if (!is_formula(type) || coefficients.empty())
        throw FormatError(cat("formula_n: ", to_string(type), " with ", coefficients.size(),
                              " coefficients is not a dispersion formula"));
    const double n2 = formula_n_squared(type, coefficients, wavelength_um);
    if (!(std::isfinite(n2) && n2 > 0.0))
        throw NumericalError(cat(to_string(type), " gives n^2 = ", n2, " at ",
                                 wavelength_um * 1000.0, " nm (beyond the fit's validity)"));
    return std::sqrt(n2);
}

// ---------------------------------------------------------------------------------------------
// Validation of user data

std::vector<std::string> nk_table_problems(std::span<const NkRow> rows, std::string_view path) {
    std::vector<std::string> problems;
    if (rows.size() < 2)
        problems.push_back(
            cat(path, ": needs at least 2 rows [wavelength_nm, n, k] (got ", rows.size(), ")"));
    for (std::size_t i = 0; i < rows.size(); ++i) {
        const NkRow& r = rows[i];
        const bool wavelength_ok = std::isfinite(r.wavelength_nm) && r.wavelength_nm > 0.0;
        if (!wavelength_ok)
            problems.push_back(cat(path, "[", i, "][0]: wavelength must be finite and > 0 nm (got ",
                                   r.wavelength_nm, ")"));
        if (!(std::isfinite(r.n) && r.n > 0.0))
            problems.push_back(cat(path, "[", i, "][1]: n must be finite and > 0 (got ", r.n, ")"));
        if (!(std::isfinite(r.k) && r.k >= 0.0))
            problems.push_back(cat(path, "[", i, "][2]: k must be finite and >= 0 (got ", r.k,
                                   "; k is the absorption, a non-negative number)"));
        if (i > 0 && wavelength_ok && std::isfinite(rows[i - 1].wavelength_nm) &&
            !(r.wavelength_nm > rows[i - 1].wavelength_nm))
            problems.push_back(cat(path, "[", i, "][0]: wavelength ", r.wavelength_nm,
                                   " nm is not greater than the previous row's ",
                                   rows[i - 1].wavelength_nm,
                                   " nm (rows must be sorted by strictly increasing wavelength)"));
    }
    return problems;
}

std::vector<std::string> constant_index_problems(double n, double k, std::string_view path) {
    std::vector<std::string> problems;
    if (!(std::isfinite(n) && n > 0.0))
        problems.push_back(cat(path, ": real part n must be finite and > 0 (got ", n, ")"));
    if (!(std::isfinite(k) && k >= 0.0))
        problems.push_back(cat(path, ": imaginary part k must be finite and >= 0 (got ", k,
                               "; k is the absorption, a non-negative number)"));
    return problems;
}

// ---------------------------------------------------------------------------------------------
// IndexModel

namespace {

// One contribution w * (n + i k): a constant, or the n entry and optional k entry of a file.
struct Part {
    double weight = 1.0;
    bool constant = false;
    double n0 = 1.0, k0 = 0.0;
    std::shared_ptr<const DataEntry> n_entry; // null for constants
    std::shared_ptr<const DataEntry> k_entry; // null: k = 0 (or k0 for constants)

    double n_at(double nm) const {
        if (constant) return n0;
        if (is_formula(n_entry->type))
            return formula_n(n_entry->type, n_entry->coefficients, nm / 1000.0);
        return interpolate(n_entry->wavelength_nm, n_entry->n, nm);
    }
    double k_at(double nm) const {
        if (constant) return k0;
        if (!k_entry) return 0.0;
        return interpolate(k_entry->wavelength_nm, k_entry->k, nm);
    }
    bool tabulated() const {
        return !constant && (!is_formula(n_entry->type) || k_entry != nullptr);
    }
};

WavelengthRange intersect(const WavelengthRange& a, const WavelengthRange& b) {
    return {std::max(a.min_nm, b.min_nm), std::min(a.max_nm, b.max_nm)};
}

constexpr WavelengthRange everywhere{0.0, std::numeric_limits<double>::infinity()};

} // namespace

struct IndexModel::Impl {
    std::string name;
    std::vector<Part> parts;
    WavelengthRange data_range = everywhere;
    WavelengthRange usable_range = everywhere;
    bool extended = false;
    std::string note;
};

IndexModel IndexModel::constant(double n, double k, std::string name) {
    const auto problems = constant_index_problems(n, k, name);
    if (!problems.empty()) throw InputError(join(problems, "; "));
    auto impl = std::make_shared<Impl>();
    impl->name = std::move(name);
    Part part;
    part.constant = true;
    part.n0 = n;
    part.k0 = k;
    impl->parts.push_back(part);
    return IndexModel(std::move(impl));
}

IndexModel IndexModel::from_nk_table(std::span<const NkRow> rows, std::string name) {
    if (rows.size() > max_nk_rows)
        throw LimitError(cat(name, ": ", rows.size(), " rows exceed the limit of ", max_nk_rows));
    const auto problems = nk_table_problems(rows, name);
    if (!problems.empty()) throw InputError(join(problems, "; "));
    auto entry = std::make_shared<DataEntry>();
    entry->type = DataType::TabulatedNK;
    for (const NkRow& r : rows) {
        entry->wavelength_nm.push_back(r.wavelength_nm);
        entry->n.push_back(r.n);
        entry->k.push_back(r.k);
    }
    entry->range = {rows.front().wavelength_nm, rows.back().wavelength_nm};
    auto impl = std::make_shared<Impl>();
    impl->name = std::move(name);
    Part part;
    part.n_entry = entry;
    part.k_entry = entry;
    impl->parts.push_back(part);
    impl->data_range = impl->usable_range = entry->range;
    return IndexModel(std::move(impl));
}

IndexModel IndexModel::from_file(const IndexFile& file, std::string name) {
    const DataEntry* n_entry = nullptr;
    const DataEntry* k_entry = nullptr;
    for (const DataEntry& e : file.data) {
        if (e.gives_n()) {
            if (n_entry)
                throw FormatError(cat(file.name, ":", e.line, ": a second entry that gives n (the ",
                                      "first is at line ", n_entry->line, ")"));
            n_entry = &e;
        }
        if (e.gives_k()) {
            if (k_entry)
                throw FormatError(cat(file.name, ":", e.line, ": a second entry that gives k (the ",
                                      "first is at line ", k_entry->line, ")"));
            k_entry = &e;
        }
    }
    if (!n_entry) throw FormatError(cat(file.name, ": no DATA entry gives n (only tabulated k)"));
    auto n_shared = std::make_shared<const DataEntry>(*n_entry);
    std::shared_ptr<const DataEntry> k_shared;
    if (k_entry) k_shared = k_entry == n_entry ? n_shared : std::make_shared<DataEntry>(*k_entry);
    WavelengthRange range = n_entry->range;
    if (k_entry) range = intersect(range, k_entry->range);
    if (!(range.min_nm < range.max_nm))
        throw FormatError(cat(file.name, ": the n data (", range_text(n_entry->range),
                              ") and the k data (", range_text(k_entry->range),
                              ") do not overlap"));
    auto impl = std::make_shared<Impl>();
    impl->name = std::move(name);
    Part part;
    part.n_entry = std::move(n_shared);
    part.k_entry = std::move(k_shared);
    impl->parts.push_back(std::move(part));
    impl->data_range = impl->usable_range = range;
    return IndexModel(std::move(impl));
}

IndexModel IndexModel::average(std::span<const std::pair<double, IndexModel>> parts,
                               std::string name) {
    if (parts.empty()) throw InputError(cat(name, ": an average needs at least one part"));
    double total = 0.0;
    for (const auto& [w, model] : parts) {
        if (!(std::isfinite(w) && w > 0.0))
            throw InputError(cat(name, ": weight of ", model.name(), " must be > 0 (got ", w, ")"));
        total += w;
    }
    auto impl = std::make_shared<Impl>();
    impl->name = std::move(name);
    for (const auto& [w, model] : parts) {
        for (Part p : model.m_impl->parts) {
            p.weight *= w / total;
            impl->parts.push_back(std::move(p));
        }
        impl->data_range = intersect(impl->data_range, model.data_range());
        impl->usable_range = intersect(impl->usable_range, model.usable_range());
    }
    if (!(impl->data_range.min_nm <= impl->data_range.max_nm))
        throw InputError(cat(impl->name, ": the data of its parts do not overlap"));
    impl->extended = impl->usable_range.min_nm < impl->data_range.min_nm ||
                     impl->usable_range.max_nm > impl->data_range.max_nm;
    return IndexModel(std::move(impl));
}

IndexModel IndexModel::extended(WavelengthRange usable, std::string note) const {
    if (has_table())
        throw InputError(cat("cannot extend ", name(), " to ", range_text(usable),
                             ": tabulated data are never extrapolated"));
    const WavelengthRange data = data_range();
    if (!(usable.min_nm <= data.min_nm && usable.max_nm >= data.max_nm))
        throw InputError(cat("cannot extend ", name(), " to ", range_text(usable),
                             ": the extension must contain the data range ", range_text(data)));
    auto impl = std::make_shared<Impl>(*m_impl);
    impl->usable_range = usable;
    impl->extended = usable.min_nm < data.min_nm || usable.max_nm > data.max_nm;
    if (!note.empty()) impl->note = std::move(note);
    return IndexModel(std::move(impl));
}

IndexModel IndexModel::with_range_note(std::string note) const {
    auto impl = std::make_shared<Impl>(*m_impl);
    impl->note = std::move(note);
    return IndexModel(std::move(impl));
}

IndexSample IndexModel::at(double wavelength_nm) const {
    const Impl& m = *m_impl;
    if (!(std::isfinite(wavelength_nm) && wavelength_nm > 0.0))
        throw InputError(
            cat("wavelength ", wavelength_nm, " nm for ", m.name, ": must be finite and > 0"));
    if (!m.usable_range.contains(wavelength_nm)) {
        std::string message;
        if (m.extended)
            message = cat("wavelength ", wavelength_nm, " nm is outside the usable range of ",
                          m.name, " (", range_text(m.usable_range), "; its data cover ",
                          range_text(m.data_range), ")");
        else
            message = cat("wavelength ", wavelength_nm, " nm is outside the data of ", m.name, " (",
                          range_text(m.data_range), ")");
        if (!m.note.empty()) message += ": " + m.note;
        throw InputError(message);
    }
    IndexSample s;
    s.n = 0.0;
    s.k = 0.0;
    try {
        for (const Part& p : m.parts) {
            s.n += p.weight * p.n_at(wavelength_nm);
            s.k += p.weight * p.k_at(wavelength_nm);
        }
    } catch (const NumericalError& e) {
        throw NumericalError(cat(m.name, ": ", e.what()));
    }
    s.extrapolated = !m.data_range.contains(wavelength_nm);
    return s;
}

const std::string& IndexModel::name() const {
    return m_impl->name;
}
WavelengthRange IndexModel::data_range() const {
    return m_impl->data_range;
}
WavelengthRange IndexModel::usable_range() const {
    return m_impl->usable_range;
}
bool IndexModel::is_extended() const {
    return m_impl->extended;
}

bool IndexModel::is_constant() const {
    return std::all_of(m_impl->parts.begin(), m_impl->parts.end(),
                       [](const Part& p) { return p.constant; });
}

bool IndexModel::has_table() const {
    return std::any_of(m_impl->parts.begin(), m_impl->parts.end(),
                       [](const Part& p) { return p.tabulated(); });
}

} // namespace brdf::material
