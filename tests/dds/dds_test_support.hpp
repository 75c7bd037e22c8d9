#pragma once
// What the in-process DDS tests share (tests/dds/, tests/sim/): the shared-memory profile and
// a bounded wait for what the DDS threads deliver. Their CMake defines
// ESFLEET_FASTDDS_PROFILE_DIR.

#include <chrono>
#include <functional>
#include <string>
#include <thread>

namespace esfleet::test {

/// deploy/fastdds/localhost-shm.xml.
inline const std::string kShmProfile =
    std::string(ESFLEET_FASTDDS_PROFILE_DIR) + "/localhost-shm.xml";

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
