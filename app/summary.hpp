#pragma once
// Order statistics of a sample, as every program reports them (stats.json, logs, benchmarks).

#include <vector>

namespace esfleet::app {

/// Median, p95, p99, max and mean of a sample; zeros when empty.
struct Summary {
  double median = 0, p95 = 0, p99 = 0, max = 0, mean = 0;
};
/// Quantiles interpolate linearly between the sorted values (numpy's default).
Summary summarize(std::vector<double> values);

/// The process's peak resident set size so far (getrusage's ru_maxrss), megabytes (10^6 bytes).
double peak_rss_mb();

}  // namespace esfleet::app
