// GraphWriter: a graph waiting to be written gives way to a newer one of the same key (and its
// memory goes at once), keys apart are all written, the bound holds, and the writer runs at
// the least CPU priority.
#include "maps/graph_writer.hpp"

#include <sys/resource.h>
#include <unistd.h>

#include <atomic>
#include <latch>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace strata::server {
namespace {

using ::testing::ElementsAre;
using ::testing::UnorderedElementsAre;

// The writes made, by name, in order.
class Written {
 public:
  std::function<void()> Write(std::string name) {
    return [this, name] {
      std::lock_guard lock(mutex_);
      names_.push_back(name);
    };
  }
  std::vector<std::string> names() {
    std::lock_guard lock(mutex_);
    return names_;
  }

 private:
  std::mutex mutex_;
  std::vector<std::string> names_;
};

TEST(GraphWriterTest, AWaitingGraphGivesWayToANewerOneOfTheSameKey) {
  GraphWriter writer;
  Written written;
  std::latch started(1), release(1);
  ASSERT_TRUE(writer.Keep("busy", [&] {
    started.count_down();
    release.wait();
  }));
  started.wait();  // The writer is busy: what comes now waits.
  auto first = std::make_shared<int>(1);
  const std::weak_ptr<int> first_alive = first;
  bool replaced = true;
  ASSERT_TRUE(writer.Keep(
      "m/robot", [&, held = std::move(first)] { written.Write("m v1")(); }, &replaced));
  EXPECT_FALSE(replaced);
  ASSERT_TRUE(writer.Keep("m/other robot", written.Write("m other v1"), &replaced));
  EXPECT_FALSE(replaced);
  ASSERT_TRUE(writer.Keep("m/robot", written.Write("m v2"), &replaced));
  EXPECT_TRUE(replaced);
  EXPECT_TRUE(first_alive.expired()) << "the graph given way holds its memory";
  ASSERT_TRUE(writer.Keep("m/robot", written.Write("m v3"), &replaced));
  EXPECT_TRUE(replaced);
  release.count_down();
  writer.WaitIdle();
  EXPECT_THAT(written.names(), UnorderedElementsAre("m v3", "m other v1"));

  // Once written, the key's next graph is written too.
  ASSERT_TRUE(writer.Keep("m/robot", written.Write("m v4"), &replaced));
  EXPECT_FALSE(replaced);
  writer.WaitIdle();
  EXPECT_EQ(written.names().back(), "m v4");
}

TEST(GraphWriterTest, AtMostTheBoundOfKeysWaitAndTheWriterIsNice) {
  GraphWriter writer;
  Written written;
  std::latch started(1), release(1);
  std::atomic<int> nice{-100};
  ASSERT_TRUE(writer.Keep("busy", [&] {
    nice = getpriority(PRIO_PROCESS, static_cast<id_t>(gettid()));
    started.count_down();
    release.wait();
  }));
  started.wait();
  for (std::size_t k = 0; k < kMaxGraphWritesWaiting; ++k) {
    ASSERT_TRUE(writer.Keep("map" + std::to_string(k), written.Write(std::to_string(k))));
  }
  EXPECT_FALSE(writer.Keep("one more map", written.Write("refused")));
  // A key already waiting still takes a newer graph.
  EXPECT_TRUE(writer.Keep("map0", written.Write("0 newer")));
  release.count_down();
  writer.WaitIdle();
  EXPECT_EQ(nice.load(), 19);
  EXPECT_THAT(written.names(), ElementsAre("0 newer", "1", "2", "3"));
}

}  // namespace
}  // namespace strata::server
