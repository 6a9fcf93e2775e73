#include "sim/output/background_writer.h"

#include <pthread.h>

#include <utility>

namespace restir {

BackgroundWriter::BackgroundWriter(size_t maxQueued)
    : maxQueued_(maxQueued > 0 ? maxQueued : 1), thread_([this] { Run(); }) {}

BackgroundWriter::~BackgroundWriter() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
    queue_.clear();
  }
  changed_.notify_all();
  thread_.join();
}

void BackgroundWriter::RethrowLocked(std::unique_lock<std::mutex>& lock) {
  if (!failure_) return;
  std::exception_ptr failure = failure_;
  lock.unlock();
  std::rethrow_exception(failure);
}

void BackgroundWriter::Submit(std::function<void()> job) {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return failure_ || queue_.size() < maxQueued_; });
  RethrowLocked(lock);
  queue_.push_back(std::move(job));
  lock.unlock();
  changed_.notify_all();
}

void BackgroundWriter::Drain() {
  std::unique_lock<std::mutex> lock(mutex_);
  changed_.wait(lock, [&] { return failure_ || (queue_.empty() && !running_); });
  RethrowLocked(lock);
}

void BackgroundWriter::Check() {
  std::unique_lock<std::mutex> lock(mutex_);
  RethrowLocked(lock);
}

void BackgroundWriter::Run() {
  pthread_setname_np(pthread_self(), "restir-writer");  // for top -H and perf: where the output time goes
  std::unique_lock<std::mutex> lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (stopping_) return;
    std::function<void()> job = std::move(queue_.front());
    queue_.pop_front();
    running_ = true;
    lock.unlock();
    changed_.notify_all();  // room in the queue: a blocked Submit goes on while this job runs
    std::exception_ptr failure;
    try {
      job();
    } catch (...) {
      failure = std::current_exception();
    }
    job = nullptr;  // what the job held (its images) is freed before it counts as finished
    lock.lock();
    running_ = false;
    if (failure) {
      failure_ = failure;
      queue_.clear();
    }
    changed_.notify_all();
  }
}

}  // namespace restir
