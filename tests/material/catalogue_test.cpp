// The built-in catalogue: completeness, values against tests/reference/material/index_reference.py,
// range policy and its messages, uniaxial averaging, the embedded data.

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/material/catalogue.h>
#include <brdf/material/embedded_data.h>

#include "reference_data.h"
#include "test_support.h"

#include <algorithm>
#include <filesystem>
#include <set>
#include <string>
#include <thread>
#include <vector>

namespace brdf::material {
namespace {

std::string input_error(std::string_view id, double wavelength_nm) {
    try {
        index_of(id, wavelength_nm);
    } catch (const InputError& e) {
        return e.what();
    }
    ADD_FAILURE() << id << " at " << wavelength_nm << " nm did not throw InputError";
    return {};
}

const std::vector<std::string> expected_ids{
    "tio2-rutile", "tio2-anatase", "zno",           "calcite", "hematite", "magnetite",
    "cds",         "vermilion",    "cu2o",          "silica",  "alumina",  "zns",
    "mgo",         "gold",         "silver",        "copper",  "carbon",   "soot",
    "pmma",        "polystyrene",  "polycarbonate", "air"};

TEST(Catalogue, ListsTheDocumentedMaterials) {
    EXPECT_EQ(material_ids(), expected_ids);
    for (const CatalogueEntry& e : catalogue()) {
        SCOPED_TRACE(std::string(e.id));
        EXPECT_FALSE(e.description.empty());
        EXPECT_FALSE(e.citation.empty());
        EXPECT_FALSE(e.licence.empty());
        EXPECT_FALSE(e.range_policy.empty());
        EXPECT_EQ(e.model.name(), e.id);
        EXPECT_EQ(find_material(e.id), &e);
        const bool metal = e.id == "gold" || e.id == "silver" || e.id == "copper";
        const bool binder = e.id == "pmma" || e.id == "polystyrene" || e.id == "polycarbonate";
        const MaterialKind kind = metal           ? MaterialKind::Metal
                                  : binder        ? MaterialKind::Binder
                                  : e.id == "air" ? MaterialKind::Void
                                                  : MaterialKind::Pigment;
        EXPECT_EQ(e.kind, kind) << to_string(e.kind);
        if (e.id == "air") {
            EXPECT_TRUE(e.files.empty());
            EXPECT_TRUE(e.model.is_constant());
        } else {
            EXPECT_FALSE(e.files.empty());
            EXPECT_EQ(e.licence, "CC0 1.0, refractiveindex.info database "
                                 "(data/refractiveindex/LICENSE)");
        }
    }
}

TEST(Catalogue, AliasAndUnknownIds) {
    ASSERT_NE(find_material("acrylic"), nullptr);
    EXPECT_EQ(find_material("acrylic")->id, "pmma");
    EXPECT_EQ(index_of("acrylic", 550.0).n, index_of("pmma", 550.0).n);
    EXPECT_EQ(find_material("rutile"), nullptr);
    EXPECT_EQ(find_material("PMMA"), nullptr); // IDs are case-sensitive; the message helps
    EXPECT_EQ(find_material(""), nullptr);

    const std::string all =
        "built-in materials: tio2-rutile, tio2-anatase, zno, calcite, hematite, magnetite, cds, "
        "vermilion, cu2o, silica, alumina, zns, mgo, gold, silver, copper, carbon, soot, pmma "
        "(alias acrylic), polystyrene, polycarbonate, air";
    EXPECT_EQ(input_error("rutile", 550.0),
              "unknown material \"rutile\" (did you mean \"tio2-rutile\"?); " + all);
    EXPECT_EQ(input_error("PMMA", 550.0),
              "unknown material \"PMMA\" (did you mean \"pmma\"?); " + all);
    EXPECT_EQ(input_error("tio2", 550.0),
              "unknown material \"tio2\" (did you mean \"tio2-rutile\" or \"tio2-anatase\"?); " +
                  all);
    EXPECT_EQ(input_error("slver", 550.0),
              "unknown material \"slver\" (did you mean \"silver\"?); " + all);
    EXPECT_EQ(input_error("unobtainium", 550.0), "unknown material \"unobtainium\"; " + all);
}

// Every ID at 380..780 nm in 5 nm steps (and a few other wavelengths): either the value of the
// independent Python reference (published formula forms, numpy.interp on the tables, the documented
// usable ranges) or an out-of-range InputError where the reference says "error". The tolerance
// covers rounding only: the formulas are algebraically equal, the interpolation the same.
TEST(Catalogue, EveryIdMatchesTheReferenceOrErrorsAsDocumented) {
    const auto rows = test::read_reference_csv("index_reference.csv");
    ASSERT_GT(rows.size(), 1800u);
    std::set<std::string> seen;
    for (const auto& row : rows) {
        ASSERT_EQ(row.size(), 5u);
        const std::string& id = row[0];
        const double nm = std::stod(row[1]);
        seen.insert(id);
        SCOPED_TRACE(id + " at " + row[1] + " nm");
        if (row[2] == "error") {
            const std::string message = input_error(id, nm);
            EXPECT_EQ(message.rfind(cat("wavelength ", nm, " nm is outside the "), 0), 0u)
                << message;
            continue;
        }
        const IndexSample s = index_of(id, nm);
        EXPECT_REL_NEAR(s.n, std::stod(row[2]), 1e-13);
        EXPECT_NEAR(s.k, std::stod(row[3]), 1e-13 * std::max(1.0, std::stod(row[3])));
        EXPECT_EQ(s.extrapolated, row[4] == "1");
        EXPECT_GT(s.n, 0.0);
        EXPECT_GE(s.k, 0.0);
    }
    EXPECT_EQ(seen, std::set<std::string>(expected_ids.begin(), expected_ids.end()));
}

TEST(Catalogue, OutOfRangeMessages) {
    EXPECT_EQ(input_error("tio2-anatase", 900.0),
              "wavelength 900 nm is outside the data of tio2-anatase (206.64-826.56 nm): "
              "tabulated data are never extrapolated; give measured data with {\"nk\": [[nm, n, "
              "k], ...]}");
    EXPECT_EQ(input_error("tio2-rutile", 370.0),
              "wavelength 370 nm is outside the usable range of tio2-rutile (380-1530 nm; its "
              "data cover 430-1530 nm): DeVore's formula holds for 430-1530 nm and is extended "
              "only down to 380 nm, because rutile absorbs strongly below ~410 nm; give measured "
              "data with {\"nk\": [[nm, n, k], ...]}");
    EXPECT_EQ(input_error("vermilion", 550.0),
              "wavelength 550 nm is outside the data of vermilion (620-11000 nm): HgS absorbs "
              "strongly below ~600 nm (which is what makes vermilion red), and Bond's formula, a "
              "fit to transparent-region data from 620 nm on, would give a white pigment there, "
              "so it is not extended; give measured visible data with {\"nk\": [[nm, n, k], "
              "...]}");
    EXPECT_EQ(input_error("soot", 400.0),
              "wavelength 400 nm is outside the data of soot (435.8-10000 nm): Dalzell and "
              "Sarofim measured from 435.8 nm on and tabulated data are never extrapolated; use "
              "\"carbon\", or give data with {\"nk\": [[nm, n, k], ...]} (theirs are nearly flat "
              "in the visible, n ~ 1.56, k ~ 0.46)");
    EXPECT_EQ(input_error("cu2o", 550.0),
              "wavelength 550 nm is outside the data of cu2o (2500-55555.6 nm): the built-in Cu2O "
              "data (Querry 1985) cover only the infrared; give measured visible data with "
              "{\"nk\": [[nm, n, k], ...]}");
    EXPECT_EQ(input_error("mgo", 781.0),
              "wavelength 781 nm is outside the usable range of mgo (380-780 nm; its data cover "
              "404.7-767.9 nm): the Stephens-Malitson visible formula holds for 404.7-767.9 nm "
              "and is extended only to 380-780 nm; give measured data with {\"nk\": [[nm, n, k], "
              "...]}");
    EXPECT_EQ(input_error("silica", -1.0), "wavelength -1 nm for silica: must be finite and > 0");
    EXPECT_EQ(index_of("air", 1e-3).n, 1.0);
}

// The range policy: only these formula materials are extended, and never a table.
TEST(Catalogue, ExtensionsAreExactlyTheDocumentedOnes) {
    std::set<std::string> extended;
    for (const CatalogueEntry& e : catalogue()) {
        if (e.model.is_extended()) extended.insert(std::string(e.id));
        if (e.model.has_table()) {
            EXPECT_FALSE(e.model.is_extended()) << e.id;
            EXPECT_EQ(e.model.usable_range().min_nm, e.model.data_range().min_nm) << e.id;
        }
        for (const CrystalAxis& a : e.axes)
            EXPECT_EQ(a.model.is_extended(), e.model.is_extended()) << e.id << " " << a.axis;
    }
    EXPECT_EQ(extended, (std::set<std::string>{"tio2-rutile", "zno", "mgo", "pmma", "polystyrene",
                                               "polycarbonate"}));
    // The extensions reach exactly 380 nm (and 780 nm for MgO, whose data stop at 767.9 nm).
    EXPECT_EQ(material("tio2-rutile").model.usable_range().min_nm, 380.0);
    EXPECT_REL_NEAR(material("tio2-rutile").model.data_range().min_nm, 430.0, 1e-12);
    EXPECT_EQ(material("mgo").model.usable_range().max_nm, 780.0);
    EXPECT_TRUE(index_of("tio2-rutile", 429.0).extrapolated);
    EXPECT_FALSE(index_of("tio2-rutile", 430.0).extrapolated);
    EXPECT_EQ(index_of("tio2-rutile", 380.0).k, 0.0); // said honestly in the docs
}

// Uniaxial crystals in random orientation: m = (2 m_o + m_e) / 3 for n and k.
TEST(Catalogue, UniaxialCrystalsAverageTwoOrdinaryAndOneExtraordinary) {
    const std::set<std::string> uniaxial{"tio2-rutile", "zno", "calcite", "hematite", "vermilion"};
    for (const CatalogueEntry& e : catalogue()) {
        SCOPED_TRACE(std::string(e.id));
        if (!uniaxial.count(std::string(e.id))) {
            ASSERT_EQ(e.axes.size(), 1u);
            EXPECT_EQ(e.axes[0].weight, 1.0);
            continue;
        }
        ASSERT_EQ(e.axes.size(), 2u);
        EXPECT_EQ(e.axes[0].axis, "o");
        EXPECT_EQ(e.axes[1].axis, "e");
        EXPECT_REL_NEAR(e.axes[0].weight, 2.0 / 3.0, 1e-15);
        EXPECT_REL_NEAR(e.axes[1].weight, 1.0 / 3.0, 1e-15);
        for (double nm : {640.0, 700.0, 780.0}) {
            const IndexSample o = e.axes[0].model.at(nm), x = e.axes[1].model.at(nm), m = e.at(nm);
            EXPECT_REL_NEAR(m.n, (2.0 * o.n + x.n) / 3.0, 1e-14) << nm;
            EXPECT_NEAR(m.k, (2.0 * o.k + x.k) / 3.0, 1e-15) << nm;
            EXPECT_NE(o.n, x.n); // really birefringent
        }
    }
    // Sanity against handbook values at the sodium D line (589.3 nm), calcite n_o = 1.6584 and
    // n_e = 1.4864: sources differ by a few 1e-4 (Ghosh's fit gives n_e = 1.4861), hence 5e-4.
    const CatalogueEntry& calcite = material("calcite");
    EXPECT_NEAR(calcite.axes[0].model.at(589.3).n, 1.6584, 5e-4);
    EXPECT_NEAR(calcite.axes[1].model.at(589.3).n, 1.4864, 5e-4);
    // Sapphire n_o at the helium d line (587.56 nm) = 1.7682 (Malitson and Dodge).
    EXPECT_NEAR(index_of("alumina", 587.56).n, 1.7682, 1e-4);
}

// The published files are kept byte for byte; what reading them repairs is listed (and documented
// in docs/materials.md). A change in the data shows up here.
TEST(Catalogue, DataRepairsAreListed) {
    const std::string ri = "data/refractiveindex/";
    EXPECT_EQ(material("cu2o").data_repairs,
              (std::vector<std::string>{
                  ri + "main_Cu2O__Querry.yml:105: wavelength 3.2680 um does not exceed the "
                       "previous row's 3.2680 um: row dropped",
                  ri + "main_Cu2O__Querry.yml:111: wavelength 3.3223 um does not exceed the "
                       "previous row's 3.3223 um: row dropped",
                  ri + "main_Cu2O__Querry.yml:10: 20 rows with k < 0 (smallest -0.023 at line "
                       "391): set to 0"}));
    EXPECT_EQ(material("hematite").data_repairs,
              (std::vector<std::string>{
                  ri + "main_Fe2O3__Querry-o.yml:386: wavelength 3.6911 um does not exceed the "
                       "previous row's 3.8760 um: row dropped",
                  ri + "main_Fe2O3__Querry-o.yml:12: 11 rows with k < 0 (smallest -0.148 at line "
                       "624): set to 0",
                  ri + "main_Fe2O3__Querry-e.yml:188: wavelength 1.9500 um does not exceed the "
                       "previous row's 1.9500 um: row dropped",
                  ri + "main_Fe2O3__Querry-e.yml:403: wavelength 4.1494 um does not exceed the "
                       "previous row's 4.1494 um: row dropped"}));
    EXPECT_EQ(material("magnetite").data_repairs,
              (std::vector<std::string>{
                  ri + "main_Fe3O4__Querry.yml:295: wavelength 2.8902 um does not exceed the "
                       "previous row's 2.8918 um: row dropped",
                  ri + "main_Fe3O4__Querry.yml:404: wavelength 4.2017 um does not exceed the "
                       "previous row's 4.2373 um: row dropped",
                  ri + "main_Fe3O4__Querry.yml:405: wavelength 4.2194 um does not exceed the "
                       "previous row's 4.2373 um: row dropped"}));
    const auto& cds = material("cds").data_repairs;
    ASSERT_EQ(cds.size(), 1u);
    EXPECT_EQ(cds[0], ri + "main_CdS__Treharne.yml:13: 192 rows with k < 0 (smallest -3.22e-17 "
                           "at line 266): set to 0");
    for (const CatalogueEntry& e : catalogue()) {
        if (e.id != "cu2o" && e.id != "hematite" && e.id != "magnetite" && e.id != "cds") {
            EXPECT_TRUE(e.data_repairs.empty()) << e.id;
        }
    }
}

// The binary carries exactly data/refractiveindex/*.yml and data/cie/*.csv, byte for byte.
TEST(Catalogue, EmbeddedDataEqualsTheFilesInData) {
    const std::filesystem::path data = test::source_dir() / "data";
    std::set<std::string> on_disk;
    for (const char* folder : {"refractiveindex", "cie"})
        for (const auto& f : std::filesystem::directory_iterator(data / folder)) {
            const std::string ext = f.path().extension().string();
            if (ext == ".yml" || ext == ".csv")
                on_disk.insert(std::string(folder) + "/" + f.path().filename().string());
        }
    std::set<std::string> embedded;
    for (const EmbeddedFile& f : embedded::material_data()) {
        embedded.insert(std::string(f.path));
        EXPECT_EQ(f.data, test::read_file(data / std::string(f.path))) << f.path;
    }
    EXPECT_EQ(embedded, on_disk);
    EXPECT_TRUE(std::filesystem::exists(data / "refractiveindex" / "LICENSE"));
    for (const CatalogueEntry& e : catalogue())
        for (std::string_view file : e.files)
            EXPECT_TRUE(embedded.count(std::string(file))) << file;
}

// The first use may come from many threads at once (each CTest entry is its own process, so this
// really is the first use): all see one fully built catalogue.
TEST(Catalogue, FirstUseFromManyThreads) {
    constexpr int threads = 8;
    std::vector<double> n(threads);
    std::vector<std::thread> pool;
    pool.reserve(threads);
    for (int t = 0; t < threads; ++t)
        pool.emplace_back([&n, t] { n[t] = index_of(t % 2 ? "hematite" : "cds", 550.0).n; });
    for (auto& th : pool) th.join();
    for (int t = 0; t < threads; ++t)
        EXPECT_EQ(n[t], index_of(t % 2 ? "hematite" : "cds", 550.0).n);
}

} // namespace
} // namespace brdf::material
