// The per-thread BxDF scratch arena (render/materials/bxdf_arena.h): BxDFs live in the block,
// the block rewinds once all of them are released, what does not fit goes to the heap, and a
// BxDF made there evaluates as one made on the heap.
#include <gtest/gtest.h>

#include <numbers>
#include <thread>
#include <vector>

#include "lensim/render/materials/bxdf_arena.h"

using namespace lensim;
using namespace lensim::render;

TEST(BxDFArena, BxDFsLiveInTheBlockAndItRewindsWhenAllAreReleased) {
  ScratchArena& arena = ScratchArena::local();
  ASSERT_EQ(arena.live(), 0u);
  const void* first = nullptr;
  {
    auto a = makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
    auto b = makeBxDF<DielectricBxDF>(1.5, TrowbridgeReitz(0.1, 0.1));
    EXPECT_TRUE(arena.owns(a.get()));
    EXPECT_TRUE(arena.owns(b.get()));
    EXPECT_NE(a.get(), static_cast<const void*>(b.get()));
    EXPECT_EQ(arena.live(), 2u);
    first = a.get();
    a.reset();
    EXPECT_EQ(arena.live(), 1u);
    // b is still live: a new BxDF must not land on it.
    auto c = makeBxDF<DiffuseBxDF>(SampledSpectrum(0.25));
    EXPECT_NE(static_cast<const void*>(c.get()), static_cast<const void*>(b.get()));
  }
  EXPECT_EQ(arena.live(), 0u);
  // Everything released: the next BxDF reuses the start of the block.
  auto d = makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
  EXPECT_EQ(static_cast<const void*>(d.get()), first);
}

TEST(BxDFArena, WhatDoesNotFitGoesToTheHeap) {
  ScratchArena& arena = ScratchArena::local();
  std::vector<std::shared_ptr<const BxDF>> held;
  bool spilled = false;
  for (size_t i = 0; i < ScratchArena::kBytes / sizeof(DiffuseBxDF) + 8; ++i) {
    held.push_back(makeBxDF<DiffuseBxDF>(SampledSpectrum(double(i))));
    if (!arena.owns(held.back().get())) spilled = true;
  }
  EXPECT_TRUE(spilled);
  // Every one keeps its own value (none overwritten by a later one).
  const Vec3 wo{0, 0, 1}, wi{0.6, 0, 0.8};
  for (size_t i = 0; i < held.size(); ++i)
    EXPECT_DOUBLE_EQ(held[i]->f(wo, wi, TransportMode::Radiance)[0],
                     double(i) * std::numbers::inv_pi);
  held.clear();
  EXPECT_EQ(arena.live(), 0u);
}

TEST(BxDFArena, EachThreadHasItsOwn) {
  auto here = makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
  const ScratchArena* there = nullptr;
  bool owned_there = false;
  std::thread t([&] {
    auto b = makeBxDF<DiffuseBxDF>(SampledSpectrum(0.5));
    there = &ScratchArena::local();
    owned_there = ScratchArena::local().owns(b.get());
  });
  t.join();
  EXPECT_TRUE(owned_there);
  EXPECT_NE(there, &ScratchArena::local());
  EXPECT_FALSE(ScratchArena::local().owns(nullptr));
}
