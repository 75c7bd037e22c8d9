#pragma once
// What the in-process DDS tests share (tests/dds/, tests/sim/): the shared-memory profile and
// a bounded wait for what the DDS threads deliver. Their CMake defines
// ESFLEET_FASTDDS_PROFILE_DIR and ESFLEET_SHM_TEST_PROFILE.

#include <chrono>
#include <functional>
#include <string>
#include <thread>

namespace esfleet::test {

/// tests/fastdds/localhost-shm.xml (a test profile, not shipped).
inline const std::string kShmProfile = ESFLEET_SHM_TEST_PROFILE;

/// Polls `done` every 5 ms until it holds or `timeout` passes; returns its last value.
inline bool wait_until(const std::function<bool()>& done,
                       std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (!done()) {
    if (std::chrono::steady_clock::now() > deadline) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

}  // namespace esfleet::test
