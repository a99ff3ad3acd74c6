// The phase-counter invariant under stress (label stress): random delays
// before each arrival, and four participants confined to one CPU
// (oversubscribed: spinning code must still make progress). See conformance.hpp.
#include "tests/sync/conformance.hpp"

namespace lockstep::sync::testing {
namespace {

template <class Primitive>
class ConformanceStress : public ::testing::Test {};
TYPED_TEST_SUITE(ConformanceStress, conformance_primitives, primitive_name);

TYPED_TEST(ConformanceStress, FourParticipantsRandomDelays) {
  run_conformance<TypeParam>({.participants = 4, .delay = delays::random});
}
TYPED_TEST(ConformanceStress, FourParticipantsOnOneCpu) {
  run_conformance<TypeParam>({.participants = 4, .confine_to_one_cpu = true});
}
TYPED_TEST(ConformanceStress, FourParticipantsOnOneCpuRandomDelays) {
  run_conformance<TypeParam>({.participants = 4, .delay = delays::random, .confine_to_one_cpu = true});
}

}  // namespace
}  // namespace lockstep::sync::testing
