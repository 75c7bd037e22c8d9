#include "esfleet/core/clock.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <thread>

namespace esfleet {
namespace {

TEST(Clock, RealtimeIsTheSystemClockInNanoseconds) {
  const auto before = std::chrono::duration_cast<std::chrono::nanoseconds>(
                          std::chrono::system_clock::now().time_since_epoch())
                          .count();
  const std::int64_t now = realtime_ns();
  const auto after = std::chrono::duration_cast<std::chrono::nanoseconds>(
                         std::chrono::system_clock::now().time_since_epoch())
                         .count();
  EXPECT_GE(now, before);
  EXPECT_LE(now, after);
}

TEST(Clock, ThreadCpuCountsWorkNotSleep) {
  const double t0 = thread_cpu_seconds();
  std::this_thread::sleep_for(std::chrono::milliseconds(50));
  const double slept = thread_cpu_seconds() - t0;
  EXPECT_GE(slept, 0.0);
  EXPECT_LT(slept, 0.04) << "sleeping used CPU";
  volatile double sink = 0.0;
  const double t1 = thread_cpu_seconds();
  while (thread_cpu_seconds() - t1 < 0.02) sink = sink + 1.0;
  EXPECT_GE(thread_cpu_seconds() - t1, 0.02);
}

}  // namespace
}  // namespace esfleet
