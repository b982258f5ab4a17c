/**
 * @file random_stream.h
 * @brief Seeds for the loop's random choices, derived from (run seed, run, experiment, purpose).
 *
 * Every random choice of a campaign (the designed experiment, the goal, where tidying puts an object) draws
 * from a generator seeded with streamSeed(...) of the choice's place in the campaign, never from a generator
 * that has been running since start-up. So a run that is stopped or killed after experiment k and resumed
 * makes the same choices as the uninterrupted run, and two purposes never share numbers.
 */
#pragma once

#include <cstdint>

namespace xpersif::core {

/// What a stream is drawn for: each purpose gets its own, independent numbers.
/// Friction: XPERSim's redraw of an object's friction per contact episode (world file `friction_redraw`).
enum class StreamPurpose : std::uint64_t { Design = 1, Goal = 2, GoalPush = 3, Tidy = 4, Friction = 5, Features = 6 };

/// A well-mixed 64-bit seed for (seed, run, index, purpose) (SplitMix64 finalizer over the combined values):
/// equal arguments give equal seeds; any difference gives unrelated ones.
std::uint64_t streamSeed(std::uint64_t seed, std::uint64_t run, std::uint64_t index, StreamPurpose purpose);

}  // namespace xpersif::core
