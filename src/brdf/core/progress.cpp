#include <brdf/core/progress.h>

#include <brdf/core/log.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sys/ioctl.h>
#include <unistd.h>

namespace brdf {

std::string format_duration(double seconds) {
    if (!std::isfinite(seconds) || seconds < 0.0) return "?";
    char text[64];
    const double ms = seconds * 1e3;
    if (ms < 999.5) { // three significant digits: 120 ms, 35.2 ms, 3.5 ms
        std::snprintf(text, sizeof text, ms >= 99.95 ? "%.0f ms" : ms >= 9.995 ? "%.1f ms" : "%.3g ms", ms);
    } else if (seconds < 59.95) { // 1 s, 3.42 s, 12.3 s
        std::snprintf(text, sizeof text, "%.3g s", seconds);
    } else if (std::lround(seconds) < 3600) {
        const long s = std::lround(seconds);
        std::snprintf(text, sizeof text, "%ld min %02ld s", s / 60, s % 60);
    } else {
        const long m = std::lround(seconds / 60.0);
        std::snprintf(text, sizeof text, "%ld h %02ld min", m / 60, m % 60);
    }
    return text;
}

// --- WorkProjection ----------------------------------------------------------------------------

WorkProjection::WorkProjection(std::vector<double> costs, int workers)
    : m_costs(std::move(costs)), m_started(m_costs.size(), -1.0), m_finished(m_costs.size(), 0),
      m_workers(std::max(1, workers)) {
    for (double c : m_costs) m_total += std::max(0.0, c);
}

void WorkProjection::start(std::size_t item, double now) {
    if (item >= m_costs.size()) return;
    m_started[item] = now;
    if (m_first < 0.0) m_first = now;
}

void WorkProjection::finish(std::size_t item, double now) {
    if (item >= m_costs.size() || m_finished[item] || m_started[item] < 0.0) return;
    m_finished[item] = 1;
    m_done_cost += std::max(0.0, m_costs[item]);
    m_done_seconds += now - m_started[item];
}

double WorkProjection::projected_total(double now) const {
    if (!(m_done_cost > 0.0) || m_first < 0.0) return -1.0;
    // Worker-seconds still to go: every unfinished item at the measured rate, less what the running
    // ones have done already; shared by the workers, but never by more than the items left.
    const double rate = m_done_seconds / m_done_cost;
    double left = rate * (m_total - m_done_cost);
    int unfinished = 0;
    for (std::size_t i = 0; i < m_costs.size(); ++i) {
        if (m_finished[i]) continue;
        ++unfinished;
        if (m_started[i] >= 0.0) left -= std::min(now - m_started[i], rate * std::max(0.0, m_costs[i]));
    }
    const int sharing = std::max(1, std::min(m_workers, unfinished));
    return now - m_first + std::max(0.0, left) / sharing;
}

// --- ProgressLine ------------------------------------------------------------------------------

ProgressLine::Options ProgressLine::terminal() {
    Options o;
    o.write = [](std::string_view text) {
        std::fwrite(text.data(), 1, text.size(), stderr);
        std::fflush(stderr);
    };
    o.clock = [] {
        return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
    };
    o.enabled = ::isatty(STDERR_FILENO) == 1;
    winsize ws{};
    if (::ioctl(STDERR_FILENO, TIOCGWINSZ, &ws) == 0 && ws.ws_col >= 20) {
        o.width = ws.ws_col;
    } else if (const char* columns = std::getenv("COLUMNS")) {
        const long c = std::strtol(columns, nullptr, 10);
        if (c >= 20 && c <= 1000) o.width = static_cast<std::size_t>(c);
    }
    return o;
}

ProgressLine::ProgressLine(Options options) : m_options(std::move(options)) {
    if (!m_options.write || !m_options.clock) m_options.enabled = false;
    if (m_options.width < 20) m_options.width = 20;
    m_start = m_options.clock ? m_options.clock() : 0.0;
    // Log lines (warnings while a bar is drawn) start at the left margin: they clear the bar first.
    if (m_options.enabled)
        log::set_status_line_clearer([this] {
            std::lock_guard lock(m_mutex);
            clear_locked();
        });
}

ProgressLine::~ProgressLine() {
    if (!m_options.enabled) return;
    log::set_status_line_clearer({});
    std::lock_guard lock(m_mutex);
    clear_locked();
}

void ProgressLine::set_total(std::size_t tasks) {
    std::lock_guard lock(m_mutex);
    m_total = tasks;
}

void ProgressLine::print(std::string_view text) {
    if (!m_options.enabled) return;
    std::lock_guard lock(m_mutex);
    clear_locked();
    std::string out(text);
    out += '\n';
    m_options.write(out);
    m_last_draw = -1e300; // redraw the status line at the next change
}

double ProgressLine::fraction() const {
    std::lock_guard lock(m_mutex);
    return fraction_locked();
}

double ProgressLine::eta_seconds() const {
    std::lock_guard lock(m_mutex);
    return eta_locked(m_options.clock ? m_options.clock() : 0.0);
}

void ProgressLine::attach(Progress* task) {
    std::lock_guard lock(m_mutex);
    m_tasks.push_back(task);
}

void ProgressLine::detach(Progress* task) {
    {
        std::lock_guard lock(m_mutex);
        m_tasks.erase(std::remove(m_tasks.begin(), m_tasks.end(), task), m_tasks.end());
        ++m_finished;
    }
    changed(false);
}

double ProgressLine::fraction_locked() const {
    const std::size_t total = std::max(m_total, m_finished + m_tasks.size());
    if (total == 0) return 0.0;
    double done = static_cast<double>(m_finished);
    for (const Progress* t : m_tasks) done += t->fraction();
    return std::min(1.0, done / static_cast<double>(total));
}

double ProgressLine::eta_locked(double now) const {
    // Elapsed time scaled by what is left: the remaining work goes at the average speed so far.
    // Too early (under 1% or half a second) the estimate is noise: none is given.
    const double f = fraction_locked(), elapsed = now - m_start;
    if (f < 0.01 || elapsed < 0.5) return -1.0;
    return elapsed * (1.0 - f) / f;
}

namespace {

/// Whole percent, rounded down (a bar never shows 100 % before the end), but not below a value
/// only rounding error keeps it under (0.4 is 40 %, even when the sum gives 0.39999999999999997).
int percent(double fraction) { return static_cast<int>(std::floor(fraction * 100.0 + 1e-9)); }

} // namespace

std::string ProgressLine::render_locked(double now) const {
    const double f = fraction_locked();
    constexpr int bar_cells = 20;
    const int filled = std::clamp(percent(f) * bar_cells / 100, 0, bar_cells);
    std::string line(bar_cells + 2, '.');
    line.front() = '[';
    line.back() = ']';
    std::fill_n(line.begin() + 1, filled, '#');
    char pct[16];
    std::snprintf(pct, sizeof pct, " %3d%%", percent(f));
    line += pct;
    const std::size_t total = std::max(m_total, m_finished + m_tasks.size());
    if (total > 1) line += cat("  ", m_finished, "/", total);
    const double eta = eta_locked(now);
    line += eta >= 0.0 ? "  ETA " + format_duration(eta) : std::string("  ETA ?");
    for (const Progress* t : m_tasks) {
        const std::string stage = t->current_stage();
        char task_pct[16];
        std::snprintf(task_pct, sizeof task_pct, " %d%%", percent(t->fraction()));
        line.append("  ").append(t->name());
        if (!stage.empty()) line.append(": ").append(stage);
        line.append(task_pct);
    }
    if (line.size() > m_options.width - 1) line.resize(m_options.width - 1);
    return line;
}

void ProgressLine::clear_locked() {
    if (m_drawn == 0) return;
    std::string blank(m_drawn + 2, ' ');
    blank.front() = blank.back() = '\r';
    m_options.write(blank);
    m_drawn = 0;
}

void ProgressLine::changed(bool force) {
    if (!m_options.enabled) return;
    std::lock_guard lock(m_mutex);
    const double now = m_options.clock();
    if (!force && now - m_last_draw < m_options.min_interval) return;
    m_last_draw = now;
    if (m_tasks.empty()) { // between tasks, or done: nothing to show
        clear_locked();
        return;
    }
    const std::string line = render_locked(now);
    // Spaces over what a longer previous line left, then back to the end of this one's text.
    std::string text = "\r";
    text += line;
    if (line.size() < m_drawn) text.append(m_drawn - line.size(), ' ').append("\r").append(line);
    m_options.write(text);
    m_drawn = line.size();
}

// --- Progress ----------------------------------------------------------------------------------

Progress::Progress(std::string name, std::vector<ProgressStage> stages, ProgressLine* line)
    : m_name(std::move(name)), m_stages(std::move(stages)), m_line(line) {
    for (const ProgressStage& s : m_stages) m_total_weight += std::max(0.0, s.weight);
    if (m_line) m_line->attach(this);
}

Progress::~Progress() {
    if (m_line) m_line->detach(this);
}

void Progress::stage(std::string_view name) {
    {
        std::lock_guard lock(m_mutex);
        for (std::size_t i = 0; i < m_stages.size(); ++i)
            if (m_stages[i].name == name && static_cast<int>(i) >= m_stage) {
                if (static_cast<int>(i) != m_stage) m_stage_fraction = 0.0;
                m_stage = static_cast<int>(i);
            }
    }
    if (m_line) m_line->changed(false);
}

void Progress::advance(double fraction) {
    {
        std::lock_guard lock(m_mutex);
        if (m_stage < 0 || !(fraction >= 0.0)) return;
        m_stage_fraction = std::max(m_stage_fraction, std::min(1.0, fraction));
    }
    if (m_line) m_line->changed(false);
}

void Progress::set_weight(std::string_view name, double weight) {
    {
        std::lock_guard lock(m_mutex);
        m_total_weight = 0.0;
        for (ProgressStage& s : m_stages) {
            if (s.name == name) s.weight = weight;
            m_total_weight += std::max(0.0, s.weight);
        }
    }
    if (m_line) m_line->changed(false);
}

void Progress::note(std::string_view text) {
    if (m_line && m_line->enabled())
        m_line->print(text);
    else
        log::info(text);
}

double Progress::fraction() const {
    std::lock_guard lock(m_mutex);
    if (m_stage < 0 || m_total_weight <= 0.0) return 0.0;
    double done = 0.0;
    for (int i = 0; i < m_stage; ++i) done += std::max(0.0, m_stages[static_cast<std::size_t>(i)].weight);
    done += std::max(0.0, m_stages[static_cast<std::size_t>(m_stage)].weight) * m_stage_fraction;
    return std::min(1.0, done / m_total_weight);
}

std::string Progress::current_stage() const {
    std::lock_guard lock(m_mutex);
    return m_stage < 0 ? std::string() : m_stages[static_cast<std::size_t>(m_stage)].name;
}

} // namespace brdf
