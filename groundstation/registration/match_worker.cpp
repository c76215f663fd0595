// The registration's match thread (match_worker.hpp).
#include "groundstation/registration/match_worker.hpp"

#include <utility>


namespace teamscan::registration {

MatchWorker::MatchWorker(std::vector<int> cpus) : cpus_{std::move(cpus)} {
  thread_ = std::thread([this] { run(); });
  std::unique_lock lock(mutex_);
  done_.wait(lock, [this] { return started_; });
}

MatchWorker::~MatchWorker() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_one();
  thread_.join();
}

std::uint64_t MatchWorker::submit(std::function<void()> job) {
  {
    std::lock_guard lock(mutex_);
    queue_.push_back(std::move(job));
  }
  wake_.notify_one();
  return ++submitted_;
}

void MatchWorker::wait(std::uint64_t ticket) {
  std::unique_lock lock(mutex_);
  if (completed_ >= ticket) return;
  ++waits_blocked_;
  done_.wait(lock, [&] { return completed_ >= ticket; });
}

ThreadScheduling MatchWorker::scheduling() const {
  std::lock_guard lock(mutex_);
  ThreadScheduling s = thread_scheduling(handle_, thread_id_);
  s.affinity_error = placement_error_;
  return s;
}

void MatchWorker::run() {
  {
    std::lock_guard lock(mutex_);
    thread_id_ = current_thread_id();
    handle_ = pthread_self();
    placement_error_ = set_current_thread_cpus(cpus_);
    started_ = true;
  }
  done_.notify_all();
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return stop_ || !queue_.empty(); });
    if (queue_.empty()) return;  // stopping, nothing left
    std::function<void()> job = std::move(queue_.front());
    queue_.pop_front();
    lock.unlock();
    job();
    lock.lock();
    ++completed_;
    done_.notify_all();
  }
}

}  // namespace teamscan::registration
