// The progress reporter with a fake clock and a string sink: what it draws, how often, the ETA, notes,
// quiet mode, several tasks on one line from several threads; and durations as people read them.

#include <brdf/core/log.h>
#include <brdf/core/progress.h>
#include <test_support.h>

#include <algorithm>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

namespace brdf::test {
namespace {

/// A ProgressLine writing into a string, with a clock the test sets.
struct FakeTerminal {
    std::string out;
    double now = 100.0;
    int writes = 0;
    ProgressLine::Options options(bool enabled = true) {
        ProgressLine::Options o;
        o.write = [this](std::string_view text) {
            out += text;
            ++writes;
        };
        o.clock = [this] { return now; };
        o.enabled = enabled;
        o.width = 200;
        return o;
    }
    /// What a terminal shows on its last line now: '\r' returns to the left margin, characters
    /// overwrite, '\n' starts a new line. Trailing spaces are dropped.
    std::string line() const {
        std::string shown;
        std::size_t cursor = 0;
        for (char c : out) {
            if (c == '\n') {
                shown.clear();
                cursor = 0;
            } else if (c == '\r') {
                cursor = 0;
            } else {
                if (cursor < shown.size()) shown[cursor] = c;
                else shown += c;
                ++cursor;
            }
        }
        while (!shown.empty() && shown.back() == ' ') shown.pop_back();
        return shown;
    }
};

const std::vector<ProgressStage> stages = {{"optics", 0.2}, {"solve", 0.4}, {"table", 0.3}, {"write", 0.1}};

TEST(Progress, FractionFollowsTheStageWeights) {
    Progress p("seed", stages);
    EXPECT_DOUBLE_EQ(p.fraction(), 0.0);
    p.stage("optics");
    p.advance(0.5);
    EXPECT_NEAR(p.fraction(), 0.1, 1e-12);
    p.stage("table"); // optics and solve count as done
    EXPECT_NEAR(p.fraction(), 0.6, 1e-12);
    p.advance(1.0);
    EXPECT_NEAR(p.fraction(), 0.9, 1e-12);
    p.advance(0.2); // never goes back
    EXPECT_NEAR(p.fraction(), 0.9, 1e-12);
    p.stage("solve"); // nor to an earlier stage
    EXPECT_EQ(p.current_stage(), "table");
    p.stage("write");
    p.advance(7.0); // clamped
    EXPECT_NEAR(p.fraction(), 1.0, 1e-12);
}

TEST(Progress, DrawsStageAndPercentWithCarriageReturnsOnly) {
    FakeTerminal term;
    ProgressLine line(term.options());
    Progress p("seed-tio2-white", stages, &line);
    p.stage("solve");
    p.advance(0.5);
    term.now += 0.2;
    p.advance(0.5);
    EXPECT_NE(term.line().find("seed-tio2-white: solve 40%"), std::string::npos) << term.out;
    EXPECT_NE(term.line().find(" 40%"), std::string::npos) << term.out;
    EXPECT_NE(term.line().find("[########"), std::string::npos) << term.out;
    EXPECT_EQ(term.out.find('\n'), std::string::npos) << "redraws stay on one line";
    EXPECT_EQ(term.out.find('\x1b'), std::string::npos) << "no escape sequences";
}

TEST(Progress, RedrawsAtMostTenTimesASecond) {
    FakeTerminal term;
    ProgressLine line(term.options());
    Progress p("m", stages, &line);
    p.stage("solve");
    const int before = term.writes;
    for (int i = 1; i <= 1000; ++i) { // 1000 updates within 0.5 s
        term.now += 0.0005;
        p.advance(i / 1000.0);
    }
    EXPECT_GE(term.writes - before, 4);
    EXPECT_LE(term.writes - before, 6);
}

// A stage that turns out long (a large particle's Lorenz-Mie optics) is weighed again: the fraction
// and the ETA follow the new weights at once.
TEST(Progress, AStageWeighedAgainMovesTheFractionAndTheEta) {
    FakeTerminal term;
    ProgressLine line(term.options());
    Progress p("m", {{"optics", 0.1}, {"solve", 0.45}, {"table", 0.45}}, &line);
    p.stage("optics");
    p.advance(0.1);
    term.now += 10.0;
    EXPECT_NEAR(p.fraction(), 0.01, 1e-12);
    EXPECT_NEAR(line.eta_seconds(), 990.0, 1e-6); // as if the other stages took 90 % of the time
    p.set_weight("optics", 99.1);                  // the optics: 99.1 % of the time
    EXPECT_NEAR(p.fraction(), 0.0991, 1e-12);
    EXPECT_NEAR(line.eta_seconds(), 10.0 * 0.9009 / 0.0991, 1e-6);
    p.set_weight("nothing", 5.0); // an unknown stage changes nothing
    EXPECT_NEAR(p.fraction(), 0.0991, 1e-12);
    p.stage("table");
    p.advance(1.0);
    EXPECT_NEAR(p.fraction(), 1.0, 1e-12);
}

// Two workers, items of cost 2, 2, 1, 1 taking a second per unit: the projection counts the items
// in flight (elapsed / fraction-done would first say 6 s where it takes 3), and an item running
// longer than its share is not counted beyond it.
TEST(WorkProjection, CountsTheItemsInFlightAndTheWorkers) {
    WorkProjection p({2.0, 2.0, 1.0, 1.0}, 2);
    EXPECT_LT(p.projected_total(0.0), 0.0) << "nothing to go by yet";
    p.start(0, 0.0);
    p.start(1, 0.0);
    EXPECT_LT(p.projected_total(1.0), 0.0);
    p.finish(0, 2.0);
    // Item 1 has done its 2 s too; items 2 and 3 then share the workers: 1 s more.
    EXPECT_NEAR(p.projected_total(2.0), 3.0, 1e-12);
    p.finish(1, 2.0);
    p.start(2, 2.0);
    p.start(3, 2.0);
    EXPECT_NEAR(p.projected_total(2.5), 3.0, 1e-12);
    p.finish(2, 3.0);
    // Item 3, still running at 4 s, counts as done at its share: only the time passed shows.
    EXPECT_NEAR(p.projected_total(4.0), 4.0, 1e-12);
    p.finish(3, 4.0);
    p.finish(3, 9.0); // a second finish changes nothing
    EXPECT_NEAR(p.projected_total(4.0), 4.0, 1e-12);
}

// One worker is one at a time, however many items are left: the rate times what is left.
TEST(WorkProjection, OneWorkerAddsUpTheRest) {
    WorkProjection p({1.0, 3.0, 4.0}, 1);
    p.start(0, 10.0);
    p.finish(0, 12.0); // 2 s per unit
    p.start(1, 12.0);
    EXPECT_NEAR(p.projected_total(13.0), 2.0 + 14.0, 1e-12); // 7 units of 2 s after the first
}

TEST(Progress, EtaFromElapsedTime) {
    FakeTerminal term;
    ProgressLine line(term.options());
    Progress p("m", {{"a", 1.0}, {"b", 1.0}}, &line);
    EXPECT_LT(line.eta_seconds(), 0.0) << "no estimate before anything is done";
    p.stage("b"); // half done after 10 s: 10 s to go
    term.now += 10.0;
    EXPECT_NEAR(line.fraction(), 0.5, 1e-12);
    EXPECT_NEAR(line.eta_seconds(), 10.0, 1e-9);
    p.advance(0.5); // 75 % after 10 s
    EXPECT_NEAR(line.eta_seconds(), 10.0 / 3.0, 1e-9);
    term.now += 0.2;
    p.advance(0.5);
    EXPECT_NE(term.line().find("ETA 3.4"), std::string::npos) << term.line();
}

TEST(Progress, SeveralTasksShareTheLineAndFinishedOnesCount) {
    FakeTerminal term;
    ProgressLine line(term.options());
    line.set_total(4);
    {
        Progress done("first", stages, &line);
    }
    Progress a("zno-white", stages, &line), b("cds-yellow", stages, &line);
    a.stage("table");
    b.stage("optics");
    term.now += 1.0;
    b.advance(0.5);
    EXPECT_NEAR(line.fraction(), (1.0 + 0.6 + 0.1) / 4.0, 1e-12);
    EXPECT_NE(term.line().find("1/4"), std::string::npos) << term.line();
    EXPECT_NE(term.line().find("zno-white: table 60%"), std::string::npos) << term.line();
    EXPECT_NE(term.line().find("cds-yellow: optics 10%"), std::string::npos) << term.line();
}

TEST(Progress, ShorterLineBlanksWhatTheLongerOneLeft) {
    FakeTerminal term;
    ProgressLine line(term.options());
    std::optional<Progress> a;
    a.emplace("a-very-long-material-name-indeed", stages, &line);
    a->stage("solve");
    EXPECT_NE(term.line().find("a-very-long"), std::string::npos) << term.line();
    Progress b("b", stages, &line);
    a.reset(); // a finishes while b runs
    term.now += 1.0;
    b.stage("solve");
    EXPECT_EQ(term.line().find("a-very-long"), std::string::npos) << term.line();
    EXPECT_NE(term.line().find("b: solve 20%"), std::string::npos) << term.line();
}

TEST(Progress, LinesTruncatedToTheTerminalWidth) {
    FakeTerminal term;
    ProgressLine::Options o = term.options();
    o.width = 40;
    ProgressLine line(o);
    Progress p(std::string(100, 'x'), stages, &line);
    p.stage("solve");
    EXPECT_LE(term.line().size(), 39u) << term.line();
}

TEST(Progress, NoteIsALineOfItsOwnAndTheBarComesBack) {
    FakeTerminal term;
    ProgressLine line(term.options());
    Progress p("slow", stages, &line);
    p.stage("optics");
    p.note("slow: about 3 min at \"reference\"");
    EXPECT_NE(term.out.find("slow: about 3 min at \"reference\"\n"), std::string::npos) << term.out;
    p.advance(0.5); // redrawn at once after a note
    EXPECT_NE(term.line().find("slow: optics 10%"), std::string::npos) << term.out;
}

TEST(Progress, DisabledLineWritesNothing) {
    FakeTerminal term;
    {
        ProgressLine line(term.options(false));
        line.set_total(2);
        Progress p("quiet", stages, &line);
        p.stage("solve");
        term.now += 5;
        p.advance(0.5);
        line.print("a permanent line");
    }
    EXPECT_EQ(term.out, "");
}

TEST(Progress, ClearedWhenTheLineEnds) {
    FakeTerminal term;
    {
        ProgressLine line(term.options());
        Progress p("m", stages, &line);
        p.stage("solve");
    }
    EXPECT_EQ(term.line(), "");
}

TEST(Progress, ThreadSafeUnderConcurrentTasks) {
    FakeTerminal term;
    std::mutex clock_mutex;
    ProgressLine::Options o = term.options();
    // The fake clock is shared by the threads: serialise it (the real one is thread-safe).
    o.clock = [&] {
        std::lock_guard lock(clock_mutex);
        return term.now += 0.01;
    };
    ProgressLine line(o);
    line.set_total(8);
    std::vector<std::thread> threads;
    for (int t = 0; t < 8; ++t)
        threads.emplace_back([&, t] {
            Progress p(cat("task", t), stages, &line);
            for (const ProgressStage& s : stages) {
                p.stage(s.name);
                for (int i = 1; i <= 50; ++i) p.advance(i / 50.0);
            }
        });
    for (std::thread& t : threads) t.join();
    EXPECT_DOUBLE_EQ(line.fraction(), 1.0);
}

TEST(Duration, SensiblePrecision) {
    EXPECT_EQ(format_duration(3.4217), "3.42 s");
    EXPECT_EQ(format_duration(0.12), "120 ms");
    EXPECT_EQ(format_duration(0.0352), "35.2 ms");
    EXPECT_EQ(format_duration(0.0035), "3.5 ms");
    EXPECT_EQ(format_duration(12.345), "12.3 s");
    EXPECT_EQ(format_duration(1.0), "1 s");
    EXPECT_EQ(format_duration(0.9999), "1 s");
    EXPECT_EQ(format_duration(125.2), "2 min 05 s");
    EXPECT_EQ(format_duration(3 * 3600 + 125), "3 h 02 min");
    EXPECT_EQ(format_duration(-1), "?");
}

} // namespace
} // namespace brdf::test
