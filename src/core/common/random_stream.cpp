#include "xpersif/core/common/random_stream.h"

namespace xpersif::core {
namespace {
std::uint64_t mix(std::uint64_t z) {  // SplitMix64's finalizer (Steele, Lea, Flood 2014)
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}
}  // namespace

std::uint64_t streamSeed(std::uint64_t seed, std::uint64_t run, std::uint64_t index, StreamPurpose purpose) {
  std::uint64_t h = mix(seed + 0x9e3779b97f4a7c15ULL);
  h = mix(h ^ (run + 0x9e3779b97f4a7c15ULL));
  h = mix(h ^ (index + 0x9e3779b97f4a7c15ULL));
  return mix(h ^ static_cast<std::uint64_t>(purpose));
}

}  // namespace xpersif::core
