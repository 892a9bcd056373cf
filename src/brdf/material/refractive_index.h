#pragma once
// Complex refractive indices m = n + i k as functions of the vacuum wavelength: the reader for the
// refractiveindex.info database's YAML files (a strict subset, see parse_index_file) and the
// dispersion models they use, and IndexModel, the one type every index source resolves to (a
// built-in material, a constant index, a user table).
//
// Dispersion formulas, as defined by the database (M. N. Polyanskiy, "Refractiveindex.info database
// of optical constants", Sci. Data 11, 94 (2024), and the database's doc/Dispersion formulas.pdf),
// lambda in micrometres, coefficients C1, C2, ... as listed in the file:
//   formula 1 (Sellmeier):   n^2 - 1 = C1 + sum_i C(2i) lambda^2 / (lambda^2 - C(2i+1)^2)
//   formula 2 (Sellmeier-2): n^2 - 1 = C1 + sum_i C(2i) lambda^2 / (lambda^2 - C(2i+1))
//   formula 4 (RefractiveIndex.INFO):
//       n^2 = C1 + C2 lambda^C3 / (lambda^2 - C4^C5) + C6 lambda^C7 / (lambda^2 - C8^C9)
//                + C10 lambda^C11 + C12 lambda^C13 + C14 lambda^C15 + C16 lambda^C17
//     Note the exponents: the pole is C4 raised to C5 (rutile: 0.0803^1 = 0.0803 um^2; ZnO:
//     0.3042^2 um^2), the numerator is lambda^C3, and the trailing pairs are plain power terms
//     (ZnO, MgO: -0.0071 lambda^2). Formula 4 has no implicit "1 +".
// Formulas give k = 0. Tabulated data are interpolated linearly in wavelength, n and k separately.
//
// Conventions: wavelengths in this API are vacuum wavelengths in nanometres; the files use
// micrometres and are converted on reading. k >= 0 is absorption (m = n + i k, the sign convention
// of the database and of the Mie code).

#include <complex>
#include <cstddef>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace brdf::material {

/// A closed interval of vacuum wavelengths in nanometres.
struct WavelengthRange {
    double min_nm = 0.0;
    double max_nm = 0.0;

    /// True if min_nm <= wavelength_nm <= max_nm, with a relative slack of 1e-9 so that a range
    /// converted from micrometres still contains its own end points.
    bool contains(double wavelength_nm) const;
};

/// The index at one wavelength.
struct IndexSample {
    double n = 1.0; ///< real part, > 0
    double k = 0.0; ///< imaginary part (extinction coefficient), >= 0
    /// The wavelength lies outside the data and a documented extension of a formula was used (see
    /// IndexModel::extended); worth a warning in a report.
    bool extrapolated = false;

    /// m = n + i k (k >= 0: absorption, the Mie code's convention).
    std::complex<double> complex() const { return {n, k}; }
};

/// The kinds of DATA entries this reader understands.
enum class DataType {
    Formula1,    ///< "formula 1": Sellmeier
    Formula2,    ///< "formula 2": Sellmeier-2
    Formula4,    ///< "formula 4": the database's general formula
    TabulatedNK, ///< "tabulated nk": rows "lambda n k"
    TabulatedN,  ///< "tabulated n": rows "lambda n" (k from another entry, else 0)
    TabulatedK,  ///< "tabulated k": rows "lambda k" (needs an entry that gives n)
};

/// The database's name of a data type ("formula 4", "tabulated nk").
std::string_view to_string(DataType type);

/// True for the formula types.
bool is_formula(DataType type);

/// One entry of a file's DATA list.
struct DataEntry {
    DataType type = DataType::TabulatedNK;
    int line = 0;          ///< line of its "- type:" in the file (1-based), for messages
    WavelengthRange range; ///< formula: its wavelength_range; table: first to last row
    /// Formula coefficients C1, C2, ... exactly as in the file (micrometre units); empty for
    /// tables.
    std::vector<double> coefficients;
    /// Table rows: vacuum wavelengths in nm (strictly increasing), and n and k per row. `n` is
    /// empty for "tabulated k", `k` is empty for "tabulated n". Empty for formulas.
    std::vector<double> wavelength_nm, n, k;

    bool gives_n() const { return type != DataType::TabulatedK; }
    bool gives_k() const { return type == DataType::TabulatedNK || type == DataType::TabulatedK; }
};

/// A parsed refractiveindex.info file.
struct IndexFile {
    std::string name;       ///< the name used in messages (usually the file name)
    std::string references; ///< REFERENCES, as written (may contain HTML)
    std::string comments;   ///< COMMENTS, as written; empty if absent
    std::vector<DataEntry> data;
    /// What ReadOptions::repair_tables changed, one line each ("FILE:LINE: ..."); empty in strict
    /// mode and for clean files.
    std::vector<std::string> repairs;
};

struct ReadOptions {
    /// Strict (false, the default): a table row whose wavelength does not exceed the previous
    /// row's, or with k < 0, is a FormatError. Repair (true; used for the built-in catalogue, whose
    /// files are kept byte-for-byte as published): such rows are dropped, negative k is set to 0,
    /// and each change is listed in IndexFile::repairs. Syntax errors, n <= 0 and non-finite
    /// numbers are FormatErrors in both modes.
    bool repair_tables = false;
};

/// Largest file parse_index_file accepts (bytes); larger input is a LimitError.
inline constexpr std::size_t max_index_file_bytes = 16u << 20;

/// Parses a refractiveindex.info YAML file. The subset understood: top-level keys REFERENCES and
/// COMMENTS (block "|" or plain one-line scalars), DATA (a list of entries with keys `type`,
/// `wavelength_range`, `coefficients`, `data: |`), and CONDITIONS, SPECS and PROPERTIES, whose
/// (nested) content is skipped. '#' comment lines and blank lines are ignored; tabs in indentation,
/// unknown keys, duplicate keys, formulas 3 and 5-9, malformed numbers, wrong column counts, a
/// formula without wavelength_range or with a coefficient count the formula cannot use are
/// FormatErrors "NAME:LINE: what is wrong". `name` is only used in messages.
IndexFile parse_index_file(std::string_view text, std::string_view name,
                           const ReadOptions& options = {});

/// n of a dispersion formula (Formula1, Formula2 or Formula4) at a wavelength in micrometres (the
/// database's unit), without any range check. Throws NumericalError where n^2 is not finite and
/// positive (near or beyond a pole of the fit).
double formula_n(DataType type, std::span<const double> coefficients, double wavelength_um);

/// One row of a user nk table.
struct NkRow {
    double wavelength_nm = 0.0; ///< vacuum wavelength, nm
    double n = 1.0;             ///< > 0
    double k = 0.0;             ///< >= 0
};

/// Most rows a user nk table may have (more is a LimitError).
inline constexpr std::size_t max_nk_rows = 100000;

/// Every problem of a user nk table, one message each, each starting with `path` and the row index,
/// e.g. "nk[3]: wavelength 500 nm is not greater than 550 nm of nk[2] (rows must be sorted by
/// strictly increasing wavelength)". Checks: at least 2 rows; per row finite wavelength > 0, finite
/// n > 0, finite k >= 0; strictly increasing wavelengths. The size limit is not checked here.
std::vector<std::string> nk_table_problems(std::span<const NkRow> rows,
                                           std::string_view path = "nk");

/// Every problem of a constant index n + i k (finite n > 0, finite k >= 0), messages starting with
/// `path`, e.g. "index: real part must be > 0 (got -1.5)".
std::vector<std::string> constant_index_problems(double n, double k,
                                                 std::string_view path = "index");

/// A complex refractive index as a function of the vacuum wavelength, with the wavelengths where it
/// holds. Immutable and cheap to copy (shared state); safe to use from many threads.
///
/// Range policy: data_range() is where the data hold (a formula's stated range; a table's first to
/// last row; the intersection for combined or averaged data). Tables are never extrapolated. A
/// model made only of formulas may be extended (extended()) to a wider usable_range(); samples
/// there have extrapolated = true. Any wavelength outside usable_range() is an InputError:
///   "wavelength 300 nm is outside the data of NAME (206.64-826.56 nm)"
/// followed, for extended models, by the extension and, if set, by a note saying why and what to
/// do.
class IndexModel {
  public:
    /// n + i k at every wavelength (usable range 0 to infinity). Throws InputError listing
    /// constant_index_problems(n, k). `name` appears in messages.
    static IndexModel constant(double n, double k = 0.0, std::string name = "constant index");

    /// Linear interpolation of a user table; never extrapolated. Throws LimitError above
    /// max_nk_rows rows, else InputError listing nk_table_problems(rows, name). `name` is also the
    /// path prefix of the messages (e.g. "pigments[0].material.nk").
    static IndexModel from_nk_table(std::span<const NkRow> rows, std::string name = "nk");

    /// The index a parsed file describes: its one entry that gives n (a formula, "tabulated n" or
    /// "tabulated nk") with, if present, its one entry that gives k ("tabulated k" or the same
    /// "tabulated nk"); k = 0 without one. The data range is the intersection of the two entries'.
    /// Throws FormatError for a file without an n entry, with two n or two k entries, or whose
    /// entries' ranges do not overlap.
    static IndexModel from_file(const IndexFile& file, std::string name);

    /// Weighted average sum_i w_i m_i of n and k over several models (w_i > 0, normalised to sum
    /// 1), e.g. a uniaxial crystal in random orientation: (2 m_o + m_e) / 3. The data and usable
    /// ranges are the intersections of the parts'.
    static IndexModel average(std::span<const std::pair<double, IndexModel>> parts,
                              std::string name);

    /// The same model, usable over `usable` (which must contain data_range()); samples outside the
    /// data range have extrapolated = true. Only models made of formulas can be extended: for any
    /// table this throws InputError ("tabulated data are never extrapolated"). `note` is appended
    /// to out-of-range messages (say why the range stops there and what the user can do).
    IndexModel extended(WavelengthRange usable, std::string note = {}) const;

    /// The same model with an explanatory note appended to its out-of-range messages.
    IndexModel with_range_note(std::string note) const;

    /// The index at a vacuum wavelength in nm. Throws InputError for a wavelength that is not
    /// finite and > 0 or lies outside usable_range(); NumericalError if a formula gives n^2 <= 0.
    IndexSample at(double wavelength_nm) const;

    const std::string& name() const;
    WavelengthRange data_range() const;
    WavelengthRange usable_range() const; ///< data_range() unless extended()
    bool is_extended() const;             ///< usable_range() is wider than data_range()
    bool is_constant() const;             ///< made only by constant()
    bool has_table() const;               ///< some part is tabulated (cannot be extended)

  private:
    struct Impl;
    explicit IndexModel(std::shared_ptr<const Impl> impl) : m_impl(std::move(impl)) {}
    std::shared_ptr<const Impl> m_impl;
};

} // namespace brdf::material
