#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <exception>
#include <functional>
#include <mutex>
#include <thread>
#include <utility>
#include <vector>

namespace die_cushion_ident {

/// Hands items, in the order pushed, to a consumer running on a thread of its own: a producer that reads and
/// decodes (a bag) and a consumer that analyses then run on two cores instead of one after the other. Items
/// travel in batches (one lock per batch, not per item), at most `max_batches` of them waiting, so memory
/// stays bounded however far the producer is ahead. The consumer's first exception ends its work (later items
/// are dropped, the producer is never blocked by it) and is rethrown by finish().
template <typename T>
class BatchPipe {
 public:
  explicit BatchPipe(std::function<void(const T&)> consume, std::size_t batch_size = 4096,
                     std::size_t max_batches = 16)
      : consume_(std::move(consume)),
        batch_size_(batch_size > 0 ? batch_size : 1),
        max_batches_(max_batches > 0 ? max_batches : 1),
        consumer_([this] { run(); }) {
    filling_.reserve(batch_size_);
  }
  BatchPipe(const BatchPipe&) = delete;
  BatchPipe& operator=(const BatchPipe&) = delete;

  /// Waits for the consumer (its exception, if any, is dropped here: call finish() to see it).
  ~BatchPipe() {
    try {
      finish();
    } catch (...) {
    }
  }

  void push(T item) {
    filling_.push_back(std::move(item));
    if (filling_.size() >= batch_size_) handOver();
  }

  /// Hands over what is left, waits until the consumer has taken every item, and rethrows its exception.
  void finish() {
    if (consumer_.joinable()) {
      if (!filling_.empty()) handOver();
      {
        std::lock_guard<std::mutex> lock(mutex_);
        closed_ = true;
      }
      ready_.notify_all();
      consumer_.join();
    }
    if (failure_) {
      std::exception_ptr failure = failure_;
      failure_ = nullptr;
      std::rethrow_exception(failure);
    }
  }

 private:
  void handOver() {
    std::vector<T> batch;
    batch.reserve(batch_size_);
    std::swap(batch, filling_);
    std::unique_lock<std::mutex> lock(mutex_);
    room_.wait(lock, [this] { return waiting_.size() < max_batches_; });
    waiting_.push_back(std::move(batch));
    lock.unlock();
    ready_.notify_one();
  }

  void run() {
    for (;;) {
      std::vector<T> batch;
      {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [this] { return !waiting_.empty() || closed_; });
        if (waiting_.empty()) return;
        batch = std::move(waiting_.front());
        waiting_.pop_front();
      }
      room_.notify_one();
      if (failure_) continue;  // only this thread writes it until it is joined
      try {
        for (const T& item : batch) consume_(item);
      } catch (...) {
        failure_ = std::current_exception();
      }
    }
  }

  std::function<void(const T&)> consume_;
  std::size_t batch_size_, max_batches_;
  std::vector<T> filling_;  // the producer's own
  std::mutex mutex_;
  std::condition_variable ready_, room_;
  std::deque<std::vector<T>> waiting_;
  bool closed_ = false;
  std::exception_ptr failure_;
  std::thread consumer_;  // last: it starts once everything above is built
};

}  // namespace die_cushion_ident
