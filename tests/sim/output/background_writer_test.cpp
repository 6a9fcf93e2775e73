#include "sim/output/background_writer.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace restir {
namespace {

TEST(BackgroundWriter, RunsEveryJobInSubmissionOrderBeforeDrainReturns) {
  std::vector<int> done;  // only the writer's thread appends; read after Drain
  BackgroundWriter writer(2);
  for (int k = 0; k < 50; ++k) writer.Submit([&done, k] { done.push_back(k); });
  writer.Drain();
  ASSERT_EQ(done.size(), 50u);
  for (int k = 0; k < 50; ++k) EXPECT_EQ(done[k], k);
  writer.Submit([&done] { done.push_back(50); });  // usable again after a drain
  writer.Drain();
  EXPECT_EQ(done.size(), 51u);
}

// What the jobs hold is bounded: never more than maxQueued waiting, one running and one being handed to Submit.
TEST(BackgroundWriter, HoldsAtMostItsQueueOfJobs) {
  struct Token {
    std::atomic<int>* alive;
    std::atomic<int>* peak;
    explicit Token(std::atomic<int>* a, std::atomic<int>* p) : alive(a), peak(p) {
      const int now = ++*alive;
      int seen = peak->load();
      while (now > seen && !peak->compare_exchange_weak(seen, now)) {
      }
    }
    Token(const Token&) = delete;
    ~Token() { --*alive; }
  };
  for (size_t maxQueued : {size_t{1}, size_t{2}, size_t{5}}) {
    std::atomic<int> alive{0}, peak{0};
    {
      BackgroundWriter writer(maxQueued);
      for (int k = 0; k < 40; ++k) {
        auto token = std::make_shared<Token>(&alive, &peak);
        // Slow jobs, so the submitting side outruns the writer and the queue fills.
        writer.Submit([token] { std::this_thread::sleep_for(std::chrono::milliseconds(2)); });
      }
      writer.Drain();
      EXPECT_EQ(alive.load(), 0) << "a finished job's captures are released";
    }
    EXPECT_LE(peak.load(), static_cast<int>(maxQueued) + 2) << "maxQueued " << maxQueued;
    EXPECT_GE(peak.load(), static_cast<int>(maxQueued)) << "the queue did fill (the jobs were slower)";
  }
}

TEST(BackgroundWriter, AFailedJobStopsTheQueueAndItsErrorReachesTheSubmitter) {
  std::atomic<int> ranAfter{0};
  BackgroundWriter writer(4);
  writer.Submit([] { throw std::runtime_error("frames/ris/0003.exr: No space left on device"); });
  // Jobs after the failure are dropped, or refused by Submit once the failure is known.
  bool submitThrew = false;
  for (int k = 0; k < 3; ++k) {
    try {
      writer.Submit([&ranAfter] { ++ranAfter; });
    } catch (const std::runtime_error&) {
      submitThrew = true;
      break;
    }
  }
  try {
    writer.Drain();
    if (!submitThrew) ADD_FAILURE() << "Drain did not rethrow the job's error";
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "frames/ris/0003.exr: No space left on device");
  }
  EXPECT_THROW(writer.Drain(), std::runtime_error) << "the failure stays reported";
  EXPECT_THROW(writer.Submit([] {}), std::runtime_error);
  EXPECT_EQ(ranAfter.load(), 0);
}

// Destroyed while jobs wait and after a failure (an exception unwinding the run): no hang, no throw, the waiting
// jobs are dropped.
TEST(BackgroundWriter, DestructionDropsWaitingJobsWithoutThrowing) {
  std::atomic<int> ran{0};
  {
    BackgroundWriter writer(8);
    writer.Submit([] { std::this_thread::sleep_for(std::chrono::milliseconds(200)); });
    for (int k = 0; k < 8; ++k) writer.Submit([&ran] { ++ran; });
  }
  EXPECT_LT(ran.load(), 8);
  {
    BackgroundWriter writer(2);
    writer.Submit([] { throw std::runtime_error("failed"); });
  }
  SUCCEED();
}

}  // namespace
}  // namespace restir
