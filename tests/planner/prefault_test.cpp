#include "prefault_internal.hpp"

#include <sys/mman.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <cstddef>
#include <numeric>
#include <stdexcept>
#include <vector>

#include <gtest/gtest.h>

namespace strata::internal {
namespace {

// Fresh anonymous pages, none of them in memory until something touches them.
class FreshPages {
 public:
  explicit FreshPages(std::size_t bytes) : bytes_(bytes) {
    data_ = mmap(nullptr, bytes_, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
    if (data_ == MAP_FAILED) data_ = nullptr;
  }
  ~FreshPages() {
    if (data_ != nullptr) munmap(data_, bytes_);
  }
  FreshPages(const FreshPages&) = delete;
  FreshPages& operator=(const FreshPages&) = delete;

  PageRegion region() const { return {data_, bytes_}; }
  bool mapped() const { return data_ != nullptr; }

  // How many of the pages are in memory.
  std::size_t resident() const {
    const auto page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
    std::vector<unsigned char> in((bytes_ + page - 1) / page);
    if (mincore(data_, bytes_, in.data()) != 0) return 0;
    std::size_t count = 0;
    for (unsigned char c : in) count += c & 1;
    return count;
  }
  std::size_t pages() const { return bytes_ / static_cast<std::size_t>(sysconf(_SC_PAGESIZE)); }

 private:
  void* data_ = nullptr;
  std::size_t bytes_;
};

TEST(FaultInPagesTest, FaultsInEveryPageOfEveryRegion) {
  FreshPages large(std::size_t{24} << 20);
  FreshPages small(std::size_t{3} << 20);
  ASSERT_TRUE(large.mapped() && small.mapped());
  ASSERT_EQ(large.resident(), 0u);
  ASSERT_EQ(small.resident(), 0u);
  const std::array regions{large.region(), small.region()};
  const std::atomic<bool> done{false};
  if (!FaultInPages(regions, done)) GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE";
  EXPECT_EQ(large.resident(), large.pages());
  EXPECT_EQ(small.resident(), small.pages());
}

TEST(FaultInPagesTest, StopsOnceTheFillIsDone) {
  FreshPages pages(std::size_t{16} << 20);
  ASSERT_TRUE(pages.mapped());
  const std::array regions{pages.region()};
  const std::atomic<bool> done{true};
  EXPECT_TRUE(FaultInPages(regions, done));
  EXPECT_EQ(pages.resident(), 0u);
}

TEST(FillWithPagesFaultedAheadTest, ReturnsWhatTheFillReturnsAndKeepsItsWrites) {
  std::vector<double> values;
  values.reserve(kLeastBytesToFaultAhead / sizeof(double));
  const std::array regions{CapacityOf(values)};
  const double sum = FillWithPagesFaultedAhead(regions, [&] {
    for (std::size_t i = 0; i < values.capacity(); ++i) values.push_back(static_cast<double>(i));
    return std::accumulate(values.begin(), values.end(), 0.0);
  });
  const double n = static_cast<double>(values.capacity());
  EXPECT_EQ(sum, n * (n - 1) / 2);
  ASSERT_EQ(values.size(), values.capacity());
  EXPECT_EQ(values[12345], 12345.0);
}

TEST(FillWithPagesFaultedAheadTest, RethrowsWhatTheFillThrows) {
  FreshPages pages(kLeastBytesToFaultAhead);
  ASSERT_TRUE(pages.mapped());
  const std::array regions{pages.region()};
  EXPECT_THROW(FillWithPagesFaultedAhead(regions, []() -> int { throw std::runtime_error("x"); }),
               std::runtime_error);
}

#ifdef _OPENMP
TEST(FillWithPagesFaultedAheadTest, FaultsThePagesInOnAnotherThreadWhileTheFillRuns) {
  FreshPages pages(kLeastBytesToFaultAhead);
  ASSERT_TRUE(pages.mapped());
  const std::array regions{pages.region()};
  {
    FreshPages probe(static_cast<std::size_t>(sysconf(_SC_PAGESIZE)));
    const std::array probe_regions{probe.region()};
    const std::atomic<bool> done{false};
    if (!FaultInPages(probe_regions, done))
      GTEST_SKIP() << "this kernel has no MADV_POPULATE_WRITE";
  }
  // The fill writes nothing: it waits (boundedly) for the other thread to fault every page in.
  const std::size_t seen = FillWithPagesFaultedAhead(regions, [&] {
    const auto give_up = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    std::size_t resident = pages.resident();
    while (resident < pages.pages() && std::chrono::steady_clock::now() < give_up) {
      resident = pages.resident();
    }
    return resident;
  });
  EXPECT_EQ(seen, pages.pages());
}

TEST(FillWithPagesFaultedAheadTest, SmallFillsRunAlone) {
  FreshPages pages(kLeastBytesToFaultAhead / 2);
  ASSERT_TRUE(pages.mapped());
  const std::array regions{pages.region()};
  FillWithPagesFaultedAhead(regions, [] { return 0; });
  EXPECT_EQ(pages.resident(), 0u);
}
#endif

}  // namespace
}  // namespace strata::internal
