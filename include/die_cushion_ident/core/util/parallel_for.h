#pragma once

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <exception>
#include <mutex>
#include <thread>
#include <vector>

namespace die_cushion_ident {

/// Runs body(i) for i in [0, count) on up to `jobs` threads (0: one per core), each taking the next index;
/// returns when all are done. The first exception thrown by a body is rethrown here. For independent work
/// items only (the candidates' fits and free runs): body must not touch shared mutable state.
template <typename Body>
void parallelFor(std::size_t count, int jobs, const Body& body) {
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const std::size_t threads =
      std::min<std::size_t>(count, jobs > 0 ? static_cast<std::size_t>(jobs) : static_cast<std::size_t>(cores));
  if (threads <= 1) {
    for (std::size_t i = 0; i < count; ++i) body(i);
    return;
  }
  std::atomic<std::size_t> next{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  const auto work = [&] {
    for (std::size_t i = next++; i < count; i = next++) {
      try {
        body(i);
      } catch (...) {
        std::lock_guard<std::mutex> lock(failure_mutex);
        if (!failure) failure = std::current_exception();
      }
    }
  };
  std::vector<std::thread> pool;
  for (std::size_t t = 1; t < threads; ++t) pool.emplace_back(work);
  work();
  for (auto& thread : pool) thread.join();
  if (failure) std::rethrow_exception(failure);
}

}  // namespace die_cushion_ident
