#pragma once
// The clocks esfleet measures with, in one place.

#include <cstdint>

namespace esfleet {

/// Nanoseconds since the Unix epoch on CLOCK_REALTIME: the clock latency figures use on both
/// sides of a link (hosts must be time-synchronised for them to mean anything).
std::int64_t realtime_ns();

/// CPU time the calling thread has used (CLOCK_THREAD_CPUTIME_ID), seconds: work done, not
/// time waited, whatever else runs on the machine.
double thread_cpu_seconds();

}  // namespace esfleet
