// The phase-counter invariant for every primitive, with 2, 3, 4 and 8
// participants (label unit). See conformance.hpp.
#include "tests/sync/conformance.hpp"

namespace lockstep::sync::testing {
namespace {

template <class Primitive>
class Conformance : public ::testing::Test {};
TYPED_TEST_SUITE(Conformance, conformance_primitives, primitive_name);

TYPED_TEST(Conformance, TwoParticipants) { run_conformance<TypeParam>({.participants = 2}); }
TYPED_TEST(Conformance, ThreeParticipants) { run_conformance<TypeParam>({.participants = 3}); }
TYPED_TEST(Conformance, FourParticipants) { run_conformance<TypeParam>({.participants = 4}); }
TYPED_TEST(Conformance, EightParticipants) { run_conformance<TypeParam>({.participants = 8}); }

}  // namespace
}  // namespace lockstep::sync::testing
