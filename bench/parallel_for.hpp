#pragma once
// Runs f(0) .. f(n - 1) on `threads` threads (at least one), each taking the next index until
// none are left; returns when all are done. Results must not depend on which thread ran what.

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <thread>
#include <vector>

namespace esfleet::bench {

template <typename F>
void parallel_for(int threads, std::size_t n, F&& f) {
  std::atomic<std::size_t> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, threads); ++t) {
    pool.emplace_back([&] {
      for (std::size_t i = next++; i < n; i = next++) f(i);
    });
  }
  for (auto& th : pool) th.join();
}

}  // namespace esfleet::bench
