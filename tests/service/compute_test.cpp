// The compute pipeline's service side, in process: the per-material error boundary (a bug is kind
// internal, not numerical), --accuracy as part of the spec hash, --force, and a daemon job's
// materials never overwriting another job's results of the same name.

#include <brdf/core/error.h>
#include <brdf/core/log.h>
#include <brdf/service/compute.h>

#include "spool_fixture.h"

#include <nlohmann/json.hpp>

#include <future>
#include <new>
#include <stdexcept>
#include <thread>

namespace brdf::test {
namespace {

namespace fs = std::filesystem;

/// A small analytic material: no Mie, three wavelengths, draft accuracy, the MERL table only.
std::string tiny(const std::string& name, double albedo = 0.9, const std::string& accuracy = "\"draft\"") {
    return cat(R"({"name": ")", name, R"(", "medium": {"albedo": )", albedo, R"(}, "accuracy": )", accuracy,
               R"(, "spectrum": "rgb", "outputs": ["merl"]})");
}

service::ComputeOptions cpu_into(const fs::path& dir) {
    service::ComputeOptions o;
    o.output_dir = dir;
    o.device = model::Device::Cpu;
    return o;
}

nlohmann::json report_of(const fs::path& dir, const std::string& name) {
    return nlohmann::json::parse(read_file(dir / (name + ".report.json")));
}

TEST(Compute, AnExceptionThatIsNotABrdfErrorIsAnInternalErrorOfThatMaterialOnly) {
    TempDir tmp;
    write_file(tmp / "c.json", cat(R"({"materials": [)", tiny("bug"), ", ", tiny("fine"), "]}"));
    service::ComputeOptions options = cpu_into(tmp / "out");
    options.preview = [](const model::SolvedMaterial& m, const fs::path&) {
        if (m.spec.name == "bug") throw std::logic_error("an invariant broke");
    };
    const auto outcomes = service::compute_files({tmp / "c.json"}, options);
    ASSERT_EQ(outcomes.size(), 2u);
    EXPECT_FALSE(outcomes[0].ok);
    EXPECT_EQ(outcomes[0].kind, ErrorKind::Internal);
    EXPECT_EQ(outcomes[0].error, "internal error: an invariant broke");
    EXPECT_EQ(exit_status(outcomes[0].kind), 70);
    EXPECT_STREQ(to_string(outcomes[0].kind), "internal");
    EXPECT_TRUE(outcomes[1].ok) << outcomes[1].error;
}

TEST(Compute, RunningOutOfMemoryIsAResourceLimitNotABug) {
    TempDir tmp;
    write_file(tmp / "m.json", tiny("m"));
    service::ComputeOptions options = cpu_into(tmp / "out");
    options.preview = [](const model::SolvedMaterial&, const fs::path&) { throw std::bad_alloc(); };
    const auto outcomes = service::compute_files({tmp / "m.json"}, options);
    EXPECT_EQ(outcomes.at(0).kind, ErrorKind::Limit);
    EXPECT_EQ(outcomes[0].error, "out of memory");
}

TEST(Compute, AccuracyOverrideIsPartOfTheSpecHash) {
    TempDir tmp;
    write_file(tmp / "a.json", tiny("a", 0.9, "\"reference\""));
    service::ComputeOptions options = cpu_into(tmp / "out");
    options.accuracy = "draft";
    ASSERT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).ok);
    const auto draft = report_of(tmp / "out", "a");
    EXPECT_EQ(draft["spec"]["accuracy"], "draft");
    EXPECT_EQ(draft["error_estimate"]["requested_tolerance"], 1e-2);
    // The same override again: up to date. Another one: a different spec, recomputed.
    EXPECT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).skipped);
    options.accuracy = "2e-3";
    const auto custom = service::compute_files({tmp / "a.json"}, options);
    EXPECT_TRUE(custom.at(0).ok && !custom[0].skipped) << custom[0].error;
    const auto tol = report_of(tmp / "out", "a");
    EXPECT_EQ(tol["spec"]["accuracy"], (nlohmann::json{{"tolerance", 2e-3}}));
    EXPECT_NE(tol["spec_hash"], draft["spec_hash"]);
    // The hash is the one the spec would have with that accuracy written in it.
    write_file(tmp / "b.json", tiny("a", 0.9, R"({"tolerance": 2e-3})"));
    ASSERT_TRUE(service::compute_files({tmp / "b.json"}, cpu_into(tmp / "out2")).at(0).ok);
    EXPECT_EQ(report_of(tmp / "out2", "a")["spec_hash"], tol["spec_hash"]);
}

TEST(Compute, AccuracyOverrideIsValidated) {
    TempDir tmp;
    write_file(tmp / "a.json", tiny("a"));
    service::ComputeOptions options = cpu_into(tmp / "out");
    for (const char* bad : {"fast", "0", "-1e-3", "0.9", "1e-3x"}) {
        options.accuracy = bad;
        try {
            service::compute_files({tmp / "a.json"}, options);
            ADD_FAILURE() << bad << ": accepted";
        } catch (const InputError& e) {
            EXPECT_NE(std::string(e.what()).find("--accuracy"), std::string::npos) << e.what();
        }
    }
    EXPECT_FALSE(fs::exists(tmp / "out" / "a.binary"));
}

TEST(Compute, ForceRecomputesWhatIsUpToDate) {
    TempDir tmp;
    write_file(tmp / "a.json", tiny("a"));
    service::ComputeOptions options = cpu_into(tmp / "out");
    ASSERT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).ok);
    EXPECT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).skipped);
    const auto before = fs::last_write_time(tmp / "out" / "a.binary");
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    options.force = true;
    const auto forced = service::compute_files({tmp / "a.json"}, options);
    EXPECT_TRUE(forced.at(0).ok && !forced[0].skipped);
    EXPECT_GT(fs::last_write_time(tmp / "out" / "a.binary"), before);
}

TEST(Compute, AJobDoesNotOverwriteAnotherJobsResultsOfTheSameName) {
    TempDir tmp;
    write_file(tmp / "a.json", tiny("paint", 0.9));
    write_file(tmp / "b.json", tiny("paint", 0.5));
    service::ComputeOptions options = cpu_into(tmp / "results");
    options.job = "a.json";
    ASSERT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).ok);
    const auto first = report_of(tmp / "results", "paint");
    EXPECT_EQ(first["job"], "a.json");

    options.job = "b.json";
    const auto refused = service::compute_files({tmp / "b.json"}, options);
    ASSERT_FALSE(refused.at(0).ok);
    EXPECT_EQ(refused[0].kind, ErrorKind::Input);
    EXPECT_NE(refused[0].error.find("material 'paint'"), std::string::npos) << refused[0].error;
    EXPECT_NE(refused[0].error.find("from job a.json"), std::string::npos) << refused[0].error;
    EXPECT_NE(refused[0].error.find((tmp / "results" / "paint.report.json").string()), std::string::npos)
        << refused[0].error;
    EXPECT_EQ(report_of(tmp / "results", "paint"), first) << "the first job's results stay";

    // The same content under another job's name is up to date; the owner may replace its own.
    EXPECT_TRUE(service::compute_files({tmp / "a.json"}, options).at(0).skipped);
    options.job = "a.json";
    const auto replaced = service::compute_files({tmp / "b.json"}, options);
    EXPECT_TRUE(replaced.at(0).ok && !replaced[0].skipped) << replaced[0].error;
    EXPECT_EQ(report_of(tmp / "results", "paint")["spec"]["medium"]["albedo"], 0.5);
}

TEST(Compute, TwoJobsComputingOneNameAtOnceRefuseTheSecond) {
    TempDir tmp;
    write_file(tmp / "a.json", tiny("paint", 0.9));
    write_file(tmp / "b.json", tiny("paint", 0.5));
    std::promise<void> a_inside, release_a;
    std::shared_future<void> release = release_a.get_future().share();
    service::ComputeOptions a_options = cpu_into(tmp / "results");
    a_options.job = "a.json";
    a_options.preview = [&](const model::SolvedMaterial&, const fs::path&) {
        a_inside.set_value();
        release.wait(); // a is still computing "paint" while b starts
    };
    auto a = std::async(std::launch::async, [&] { return service::compute_files({tmp / "a.json"}, a_options); });
    a_inside.get_future().wait();
    service::ComputeOptions b_options = cpu_into(tmp / "results");
    b_options.job = "b.json";
    const auto b = service::compute_files({tmp / "b.json"}, b_options);
    release_a.set_value();
    EXPECT_TRUE(a.get().at(0).ok);
    ASSERT_FALSE(b.at(0).ok);
    EXPECT_NE(b[0].error.find("is being computed by job a.json"), std::string::npos) << b[0].error;
    EXPECT_EQ(report_of(tmp / "results", "paint")["job"], "a.json");
}

} // namespace
} // namespace brdf::test
