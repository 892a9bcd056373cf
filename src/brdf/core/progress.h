#pragma once
// Progress of long computations on a terminal: one line on stderr, redrawn in place with '\r' (no
// other control characters), at most ~10 times a second, with the stage of each running task, the
// overall fraction and an ETA. Quiet when stderr is not a terminal (logs and pipes get no '\r'
// noise); the callers print their own summary line either way.
//
//   ProgressLine line(ProgressLine::terminal());      // disabled unless stderr is a terminal
//   line.set_total(materials.size());
//   Progress p("seed-tio2-white", {{"optics", 0.2}, {"solve", 0.4}, {"table", 0.3}, {"write", 0.1}},
//              &line);
//   p.note("seed-tio2-white: about 40 s at \"reference\"");   // a line of its own, kept
//   p.stage("solve");
//   p.advance(0.5);                                   // half of "solve" done
//
// Thread-safe: tasks computed in parallel each have their Progress on the same line. The clock and
// the output are injectable (ProgressLine::Options), which is how the tests drive it.

#include <cstddef>
#include <functional>
#include <mutex>
#include <string>
#include <string_view>
#include <vector>

namespace brdf {

/// "120 ms", "3.42 s", "12.3 s", "2 min 05 s", "1 h 02 min": durations for people, three significant
/// digits below a minute. Negative or non-finite input gives "?".
std::string format_duration(double seconds);

/// How long independent items of known relative cost take in all, done `workers` at a time,
/// projected from those finished so far: seconds per unit of cost from the finished items (each
/// timed from its own start), the running ones counted with the time they have run. A plain
/// elapsed / fraction-done would count nothing of the items in flight: with two workers it first
/// projects twice the time. Not thread-safe (the caller serialises).
class WorkProjection {
public:
    /// `costs`: each item's expected cost, > 0 (any unit: only ratios count).
    WorkProjection(std::vector<double> costs, int workers);
    /// Times in seconds on any one clock.
    void start(std::size_t item, double now);
    void finish(std::size_t item, double now);
    /// Seconds from the first start to the projected end of the last item; negative before an
    /// item has finished.
    double projected_total(double now) const;

private:
    std::vector<double> m_costs, m_started;
    std::vector<char> m_finished;
    double m_total = 0.0, m_done_cost = 0.0, m_done_seconds = 0.0, m_first = -1.0;
    int m_workers = 1;
};

struct ProgressStage {
    std::string name;
    double weight = 1.0; ///< share of the task's time, > 0 (normalised over the stages)
};

class Progress;

/// The one status line. Tasks (Progress) report to it; it draws when enabled.
class ProgressLine {
public:
    struct Options {
        std::function<void(std::string_view)> write; ///< receives the text to print, '\r' included
        std::function<double()> clock;               ///< seconds, monotonic
        bool enabled = false;                        ///< false: draws nothing, notes go to log::info
        double min_interval = 0.1;                   ///< seconds between redraws
        std::size_t width = 80;                      ///< terminal columns; lines are cut to width - 1
    };
    /// stderr and the steady clock; enabled when stderr is a terminal; width from the terminal (or
    /// $COLUMNS, else 80).
    static Options terminal();

    explicit ProgressLine(Options options);
    /// Clears the line.
    ~ProgressLine();
    ProgressLine(const ProgressLine&) = delete;
    ProgressLine& operator=(const ProgressLine&) = delete;

    bool enabled() const { return m_options.enabled; }
    /// How many tasks the run has (for "3/8" and the overall fraction); 0: those seen so far.
    void set_total(std::size_t tasks);
    /// Prints `text` as a line of its own above the status line (nothing when disabled).
    void print(std::string_view text);
    /// Overall fraction done, 0..1: finished tasks count 1, running ones their fraction.
    double fraction() const;
    /// Seconds left by the elapsed time and fraction(); negative while there is too little to go by.
    double eta_seconds() const;

private:
    friend class Progress;
    void attach(Progress* task);
    void detach(Progress* task);
    void changed(bool force);                 // a task moved: redraw if it is time
    void clear_locked();                      // erase what is drawn
    std::string render_locked(double now) const;
    double fraction_locked() const;
    double eta_locked(double now) const;

    Options m_options;
    mutable std::mutex m_mutex; // guards everything below
    std::vector<Progress*> m_tasks;
    std::size_t m_total = 0, m_finished = 0;
    double m_start = 0.0, m_last_draw = -1e300;
    std::size_t m_drawn = 0; // characters on the line now
};

/// One task (a material): named stages with weights, each advanced from 0 to 1.
class Progress {
public:
    /// `line` may be null: then the task only keeps its fraction (and notes go to log::info).
    Progress(std::string name, std::vector<ProgressStage> stages, ProgressLine* line = nullptr);
    /// The task counts as finished from here on.
    ~Progress();
    Progress(const Progress&) = delete;
    Progress& operator=(const Progress&) = delete;

    /// Starts stage `name` (earlier stages count as complete); an unknown name is ignored.
    void stage(std::string_view name);
    /// Fraction of the current stage done, clamped to 0..1; never goes back.
    void advance(double fraction);
    /// Gives stage `name` another weight, for a caller that learns how long it will take (compute:
    /// the projected seconds of a material's Lorenz-Mie optics). The task's fraction moves with it,
    /// either way; an unknown name is ignored.
    void set_weight(std::string_view name, double weight);
    /// Something a user should know before waiting, e.g. the estimated time of a long material: a
    /// line of its own on a terminal, log::info otherwise.
    void note(std::string_view text);

    const std::string& name() const { return m_name; }
    /// Overall fraction of this task, 0..1.
    double fraction() const;
    /// The current stage's name ("" before the first stage()).
    std::string current_stage() const;

private:
    std::string m_name;
    std::vector<ProgressStage> m_stages;
    double m_total_weight = 0.0;
    ProgressLine* m_line;
    mutable std::mutex m_mutex; // guards the two below
    int m_stage = -1;
    double m_stage_fraction = 0.0;
};

} // namespace brdf
