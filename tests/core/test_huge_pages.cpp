#include <catch2/catch.hpp>

#include <cstdint>
#include <numeric>

#include "pipeline/core/huge_pages.h"

using frontmesh::core::HugePageAllocator;
using frontmesh::core::HugeVector;

namespace {

struct alignas(64) Line {
    double v[8];
};

bool aligned_to(const void* p, std::size_t a) {
    return reinterpret_cast<std::uintptr_t>(p) % a == 0;
}

}  // namespace

TEST_CASE("HugeVector keeps its contents across growth from small to huge blocks", "[huge_pages]") {
    // 3 M ints = 12 MB: the buffer passes from operator new to its own 2 MiB aligned mappings.
    HugeVector<std::int32_t> v;
    for (std::int32_t i = 0; i < 3'000'000; ++i) v.push_back(i * 7);
    REQUIRE(v.size() == 3'000'000u);
    CHECK(aligned_to(v.data(), HugePageAllocator<std::int32_t>::kPage));
    bool same = true;
    for (std::int32_t i = 0; i < 3'000'000; ++i)
        same = same && v[static_cast<std::size_t>(i)] == i * 7;
    CHECK(same);
    // Shrinking back below 2 MiB frees the mapping and copies into a small block.
    v.resize(1000);
    v.shrink_to_fit();
    CHECK(v.capacity() == 1000u);
    CHECK(v[999] == 999 * 7);
}

TEST_CASE("HugeVector honours over-aligned element types in small blocks", "[huge_pages]") {
    HugeVector<Line> small(3);
    CHECK(aligned_to(small.data(), 64));
    HugeVector<Line> big(40'000);  // 2.56 MB
    CHECK(aligned_to(big.data(), HugePageAllocator<Line>::kPage));
    big[39'999].v[7] = 1.5;
    HugeVector<Line> copy = big;
    CHECK(copy[39'999].v[7] == 1.5);
}
