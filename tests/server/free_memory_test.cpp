// KeepFreedMemoryForReuse: a large block freed serves the next one in the pages it had.
// FreeMemoryReturner: memory a program freed between blocks it still holds, which glibc keeps,
// goes back to the system after a request. Built without sanitisers in every tree
// (tests/server/CMakeLists.txt): a sanitiser's allocator would serve malloc instead of glibc's.
#include "common/free_memory.hpp"

#include <sys/resource.h>

#include <chrono>
#include <cstddef>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

namespace strata::server {
namespace {

// Page faults this process took to map memory in (minor: no disk read).
long MinorFaults() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_minflt;
}

// Writes a byte on every page of `block`: each page is mapped in.
void Touch(char* block, std::size_t bytes) {
  for (std::size_t i = 0; i < bytes; i += 4096) static_cast<volatile char*>(block)[i] = 1;
}

// A new version's arrays are the size of the last one's, freed just before: they must land in
// its pages, not in new ones the kernel maps in (and, on some hosts, takes seconds to).
TEST(KeepFreedMemoryForReuseTest, ALargeBlockFreedServesTheNextWithoutNewPages) {
  KeepFreedMemoryForReuse();
  constexpr std::size_t kBytes = 256u << 20;
  constexpr long kPages = kBytes / 4096;
  {
    const std::unique_ptr<char[]> version(new char[kBytes]);
    Touch(version.get(), kBytes);
  }
  const long before = MinorFaults();
  {
    const std::unique_ptr<char[]> next(new char[kBytes + 64 * 1024]);  // A little larger.
    Touch(next.get(), kBytes + 64 * 1024);
  }
  EXPECT_LT(MinorFaults() - before, kPages / 20) << "of " << kPages << " pages";
}

// 160 MB freed in blocks of 64 KiB (below glibc's mmap threshold: on its heap), each followed
// by a small block that stays in `kept`: the freed blocks cannot merge into the heap's top,
// which glibc would return by itself.
constexpr std::size_t kBlock = 64 * 1024;
constexpr int kBlocks = 2500;
void FreeBetweenBlocksKept(std::vector<std::unique_ptr<char[]> >* kept) {
  std::vector<std::unique_ptr<char[]> > freed;
  for (int i = 0; i < kBlocks; ++i) {
    freed.push_back(std::make_unique<char[]>(kBlock));  // Zeroed: its pages are touched.
    kept->push_back(std::make_unique<char[]>(64));
  }
}

TEST(FreeMemoryReturnerTest, GivesBackMemoryFreedBetweenBlocksStillHeld) {
  std::vector<std::unique_ptr<char[]> > kept;
  FreeBetweenBlocksKept(&kept);
  const std::size_t before = ResidentBytes();

  FreeMemoryReturner returner(std::chrono::milliseconds(0));
  returner.Request();
  ASSERT_TRUE(returner.WaitIdle(std::chrono::seconds(60)));
  const std::size_t after = ResidentBytes();
  EXPECT_GT(before, after + kBlocks * kBlock / 2) << "resident " << before << " -> " << after;
}

// While versions keep coming the quiet period never ends: what is free beyond the room asked
// for goes back at once, and within it stays for the next version. (Twice the room let a
// 400 m site's scan soak grow 1.6 GB in 5 minutes; one room, 0.6 GB, lower at its end.)
TEST(FreeMemoryReturnerTest, GivesBackAtOnceOnlyWhatIsFreeBeyondTheRoom) {
  std::vector<std::unique_ptr<char[]> > kept;
  FreeBetweenBlocksKept(&kept);
  const std::size_t before = ResidentBytes();
  FreeMemoryReturner returner(std::chrono::hours(1));

  FreeMemoryReturner::Room room(returner);

  room.Request(std::size_t{1} << 30);  // Room for 1 GiB: the 160 MB free stay.
  EXPECT_GT(ResidentBytes() + kBlocks * kBlock / 2, before);

  room.Request(before * 2 / 3);  // The process holds more than the room, less than twice it.
  ASSERT_TRUE(returner.WaitIdle(std::chrono::seconds(60)));
  const std::size_t after = ResidentBytes();
  EXPECT_GT(before, after + kBlocks * kBlock / 2) << "resident " << before << " -> " << after;
}

// Replicas side by side in one process (a benchmark's) each keep room for their next version:
// the rooms add up while their holders live, and a holder's last word stands until it is gone.
TEST(FreeMemoryReturnerTest, KeepsTheRoomsOfItsHoldersTogether) {
  FreeMemoryReturner returner(std::chrono::hours(1));
  FreeMemoryReturner::Room first(returner);
  first.Request(100u << 20);
  {
    FreeMemoryReturner::Room second(returner);
    second.Request(50u << 20);
    EXPECT_EQ(returner.RoomBytes(), 150u << 20);
    second.Request();  // No new figure: the last stands.
    EXPECT_EQ(returner.RoomBytes(), 150u << 20);
  }
  EXPECT_EQ(returner.RoomBytes(), 100u << 20);
}

}  // namespace
}  // namespace strata::server
