// The oscillator models and the staged RK4: equations, dependency sets, and
// the bitwise identity of the per-element (parallel-style) evaluation with the
// serial staged RK4.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <set>
#include <vector>

#include "kernels/oscillator.hpp"
#include "kernels/rk4.hpp"

namespace {

using lockstep::kernels::block_dependencies;
using lockstep::kernels::chain_model;
using lockstep::kernels::chain_params;
using lockstep::kernels::dependency_set;
using lockstep::kernels::kRk4Stages;
using lockstep::kernels::rk4_coefficients;
using lockstep::kernels::rk4_stage_derivative;
using lockstep::kernels::rk4_update;
using lockstep::kernels::staged_rk4;
using lockstep::kernels::two_mass_model;
using lockstep::kernels::two_mass_params;

// Bitwise equality of two trajectories' states (distinguishes -0.0, NaN payloads).
void expect_same_bits(std::span<const double> expected, std::span<const double> actual) {
  ASSERT_EQ(expected.size(), actual.size());
  for (std::size_t index = 0; index < expected.size(); ++index) {
    EXPECT_EQ(std::bit_cast<std::uint64_t>(expected[index]), std::bit_cast<std::uint64_t>(actual[index]))
        << "element " << index << ": " << expected[index] << " vs " << actual[index];
  }
}

// A stage_values view that records which elements a derivative reads.
struct recording_values {
  std::array<double, 16> values{};
  mutable std::set<std::size_t> read;
  double operator[](std::size_t index) const {
    read.insert(index);
    return values.at(index);
  }
};

TEST(TwoMassModel, PapersCaseIsTheDefault) {
  const two_mass_params params;
  EXPECT_DOUBLE_EQ(params.c1 / params.m1, 1012.5);
  EXPECT_DOUBLE_EQ(params.c2 / params.m2, 1012.5);
  EXPECT_TRUE(params.is_papers_case());
  const two_mass_model model;
  EXPECT_EQ(model.initial_state(), (std::vector<double>{2.0, -3.0, 0.0, 0.0}));
}

TEST(TwoMassModel, EquationsAreThePapersD1ToD4) {
  const two_mass_params params{.m1 = 2.0, .m2 = 5.0, .c1 = 3.0, .c2 = 7.0};
  const two_mass_model model(params);
  const std::array<double, 4> y{1.5, -0.25, 4.0, -8.0};
  EXPECT_EQ(model.derivative(0, y), 4.0);
  EXPECT_EQ(model.derivative(1, y), -8.0);
  EXPECT_NEAR(model.derivative(2, y), (7.0 * (-0.25 - 1.5) - 3.0 * 1.5) / 2.0, 1e-14);
  EXPECT_NEAR(model.derivative(3, y), 7.0 * (1.5 - -0.25) / 5.0, 1e-14);
}

TEST(TwoMassModel, DependencySetsAreThePapers) {
  EXPECT_EQ(two_mass_model::dependencies(0), (dependency_set{{2, 0, 0}, 1}));
  EXPECT_EQ(two_mass_model::dependencies(1), (dependency_set{{3, 0, 0}, 1}));
  EXPECT_EQ(two_mass_model::dependencies(2), (dependency_set{{0, 1, 0}, 2}));
  EXPECT_EQ(two_mass_model::dependencies(3), (dependency_set{{0, 1, 0}, 2}));
}

// Each derivative reads exactly the elements its dependency set names, so a
// dataflow synchronisation that waits only for those producers is enough.
template <class Model>
void expect_derivatives_read_only_dependencies(const Model& model) {
  for (std::size_t equation = 0; equation < model.equations(); ++equation) {
    recording_values values;
    for (std::size_t index = 0; index < model.equations(); ++index) values.values.at(index) = 0.5 + static_cast<double>(index);
    (void)model.derivative(equation, values);
    const dependency_set dependencies = model.dependencies(equation);
    const std::set<std::size_t> expected(dependencies.begin(), dependencies.end());
    EXPECT_EQ(values.read, expected) << "equation " << equation;
    EXPECT_TRUE(std::is_sorted(dependencies.begin(), dependencies.end()));
  }
}

TEST(TwoMassModel, DerivativesReadOnlyTheirDependencies) {
  expect_derivatives_read_only_dependencies(two_mass_model{});
}

TEST(ChainModel, DerivativesReadOnlyTheirDependencies) {
  for (std::size_t masses : {1U, 2U, 3U, 5U}) expect_derivatives_read_only_dependencies(chain_model(chain_params::uniform(masses)));
}

// Mass by mass: x_1, v_1, x_2, v_2, ... (equations 0, 1, 2, 3, ...).
TEST(ChainModel, NumbersMassByMass) {
  const chain_model chain(chain_params::uniform(4));
  for (std::size_t mass = 0; mass < 4; ++mass) {
    EXPECT_EQ(chain.position_equation(mass), 2 * mass);
    EXPECT_EQ(chain.velocity_equation(mass), 2 * mass + 1);
  }
  chain_params params = chain_params::uniform(3);
  params.velocities = {0.5, -0.25, 0.125};
  EXPECT_EQ(chain_model(params).initial_state(), (std::vector<double>{2.0, 0.5, -3.0, -0.25, 2.0, 0.125}));
  EXPECT_EQ(chain.block_grain(), 2U) << "a mass's position and velocity stay with one owner";
  EXPECT_EQ(two_mass_model::block_grain(), 1U) << "the paper's split: one equation per thread";
}

TEST(ChainModel, DependenciesAreTridiagonalNeighbours) {
  const chain_model chain(chain_params::uniform(4));
  EXPECT_EQ(chain.dependencies(0), (dependency_set{{1, 0, 0}, 1}));   // x_1 reads v_1
  EXPECT_EQ(chain.dependencies(6), (dependency_set{{7, 0, 0}, 1}));   // x_4 reads v_4
  EXPECT_EQ(chain.dependencies(1), (dependency_set{{0, 2, 0}, 2}));   // v_1 reads x_1, x_2 (the wall is fixed)
  EXPECT_EQ(chain.dependencies(3), (dependency_set{{0, 2, 4}, 3}));   // v_2 reads x_1, x_2, x_3
  EXPECT_EQ(chain.dependencies(7), (dependency_set{{4, 6, 0}, 2}));   // v_4 reads x_3, x_4 (the last is free)
}

// The block evaluation gives derivative()'s bits for every block of every
// chain, whatever the block's ends (a position or a velocity, the wall or
// the free end).
TEST(ChainModel, BlockDerivativesAreBitwiseThePerEquationOnes) {
  for (std::size_t masses : {1U, 2U, 3U, 4U, 7U}) {
    chain_params params = chain_params::uniform(masses);
    for (std::size_t mass = 0; mass < masses; ++mass) params.masses[mass] = 0.02 + 0.003 * static_cast<double>(mass);
    const chain_model chain(params);
    const std::size_t n = chain.equations();
    std::vector<double> y(n);
    for (std::size_t index = 0; index < n; ++index) y[index] = std::sin(1.0 + 0.7 * static_cast<double>(index)) * 3.0;
    for (std::size_t first = 0; first <= n; ++first)
      for (std::size_t last = first; last <= n; ++last) {
        std::vector<double> block(last - first + 1, -1.0e300);
        chain.derivatives(first, last, y.data(), block.data());
        for (std::size_t equation = first; equation < last; ++equation)
          EXPECT_EQ(std::bit_cast<std::uint64_t>(block[equation - first]),
                    std::bit_cast<std::uint64_t>(chain.derivative(equation, y.data())))
              << masses << " masses, block [" << first << ", " << last << "), equation " << equation;
        EXPECT_EQ(block[last - first], -1.0e300) << "wrote past the block [" << first << ", " << last << ")";
      }
  }
}

TEST(ChainModel, BlockDependenciesExcludeTheBlockItself) {
  const two_mass_model model;
  EXPECT_EQ(block_dependencies(model, 0, 2), (std::vector<std::size_t>{2, 3}));
  EXPECT_EQ(block_dependencies(model, 2, 4), (std::vector<std::size_t>{0, 1}));
  EXPECT_EQ(block_dependencies(model, 0, 4), (std::vector<std::size_t>{}));
  EXPECT_EQ(block_dependencies(model, 2, 3), (std::vector<std::size_t>{0, 1}));
}

TEST(ChainModel, RejectsNonPhysicalParameters) {
  chain_params params = chain_params::uniform(3);
  params.masses[1] = 0.0;
  EXPECT_THROW(chain_model{params}, std::invalid_argument);
  params = chain_params::uniform(3);
  params.springs[2] = std::nan("");
  EXPECT_THROW(chain_model{params}, std::invalid_argument);
  params = chain_params::uniform(3);
  params.positions.pop_back();
  EXPECT_THROW(chain_model{params}, std::invalid_argument);
  EXPECT_THROW(chain_model{chain_params{}}, std::invalid_argument);
  EXPECT_THROW(two_mass_model(two_mass_params{.m1 = -1.0}), std::invalid_argument);
  EXPECT_THROW(two_mass_model(two_mass_params{.c2 = INFINITY}), std::invalid_argument);
}

// The same operations on the same values, numbered differently: the chain's
// x_1, v_1, x_2, v_2 are the pair's x1, x3, x2, x4.
TEST(ChainModel, TwoMassChainIsBitwiseTheTwoMassModel) {
  const two_mass_params params{.m1 = 0.03, .m2 = 0.017, .c1 = 21.0, .c2 = 13.5, .x1 = 1.25, .x2 = -0.5, .v1 = 3.0};
  staged_rk4 pair(two_mass_model(params), 1e-3);
  const chain_model chain_of_two(chain_params::from_two_mass(params));
  staged_rk4 chain(chain_of_two, 1e-3);
  pair.run(5000);
  chain.run(5000);
  std::vector<double> renumbered(4);
  for (std::size_t mass = 0; mass < 2; ++mass) {
    renumbered[two_mass_model::position_equation(mass)] = chain.state()[chain_of_two.position_equation(mass)];
    renumbered[two_mass_model::velocity_equation(mass)] = chain.state()[chain_of_two.velocity_equation(mass)];
  }
  expect_same_bits(pair.state(), renumbered);
}

TEST(StagedRk4, EnergyOfTheInitialState) {
  const two_mass_model model;
  // 1/2 C x1^2 + 1/2 C (x2 - x1)^2 = 1/2 * 20.25 * (4 + 25)
  EXPECT_DOUBLE_EQ(model.energy(model.initial_state()), 0.5 * 20.25 * 29.0);
  const chain_model chain(chain_params::uniform(2));
  EXPECT_DOUBLE_EQ(chain.energy(chain.initial_state()), 0.5 * 20.25 * 29.0);
}

// What a parallel step does: equations in any order (here: blocks, reversed),
// each through rk4_stage_derivative reading x and k_{s-1} directly, the
// update per element. It must give the serial staged RK4's bits.
template <class Model>
std::vector<double> per_element_trajectory(const Model& model, double step, int steps, std::size_t block) {
  const rk4_coefficients coefficients(step);
  const std::size_t n = model.equations();
  std::vector<double> x = model.initial_state();
  std::array<std::vector<double>, kRk4Stages> k;
  for (auto& values : k) values.assign(n, -1.0e300);  // garbage: stage 0 must not read it
  for (int done = 0; done < steps; ++done) {
    for (unsigned stage = 0; stage < kRk4Stages; ++stage) {
      const std::vector<double>& previous = k[stage == 0 ? 0 : stage - 1];
      std::vector<double> next(n);
      for (std::size_t first = 0; first < n; first += block) {
        const std::size_t last = std::min(n, first + block);
        for (std::size_t equation = last; equation-- > first;) {
          next[equation] = rk4_stage_derivative(model, coefficients, stage, equation, x, previous);
        }
      }
      k[stage] = next;
    }
    for (std::size_t element = n; element-- > 0;) {
      x[element] = rk4_update(coefficients, x[element], k[0][element], k[1][element], k[2][element], k[3][element]);
    }
  }
  return x;
}

TEST(StagedRk4, PerElementEvaluationIsBitwiseTheSerialStep) {
  const two_mass_model model;
  for (std::size_t block : {1U, 2U, 4U}) {
    staged_rk4 serial(model, 1e-3);
    serial.run(2000);
    expect_same_bits(serial.state(), per_element_trajectory(model, 1e-3, 2000, block));
  }
  const chain_model chain(chain_params::uniform(5));
  for (std::size_t block : {1U, 3U, 4U}) {
    staged_rk4 serial(chain, 5e-4);
    serial.run(1000);
    expect_same_bits(serial.state(), per_element_trajectory(chain, 5e-4, 1000, block));
  }
}

TEST(StagedRk4, StageInputAndUpdateFollowTheDocumentedOrder) {
  const rk4_coefficients coefficients(0.1);
  EXPECT_EQ(coefficients.stage_scale(0), 0.0);
  EXPECT_EQ(coefficients.stage_scale(1), 0.05);
  EXPECT_EQ(coefficients.stage_scale(2), 0.05);
  EXPECT_EQ(coefficients.stage_scale(3), 0.1);
  EXPECT_EQ(coefficients.sixth_step(), 0.1 / 6.0);
  // Stage 0 is x itself, bit for bit, whatever k_previous holds.
  EXPECT_EQ(std::bit_cast<std::uint64_t>(lockstep::kernels::rk4_stage_input(coefficients, 0, -0.0, INFINITY)),
            std::bit_cast<std::uint64_t>(-0.0));
  EXPECT_EQ(lockstep::kernels::rk4_stage_input(coefficients, 3, 1.0, 2.0), 1.0 + 0.1 * 2.0);
  const double k0 = 0.1, k1 = 1e17, k2 = -1e17, k3 = 3.0;
  double weighted = k0 + 2.0 * k1;
  weighted = weighted + 2.0 * k2;
  weighted = weighted + k3;
  EXPECT_EQ(rk4_update(coefficients, 1.0, k0, k1, k2, k3), 1.0 + (0.1 / 6.0) * weighted);
  EXPECT_THROW(rk4_coefficients(0.0), std::invalid_argument);
  EXPECT_THROW(rk4_coefficients(-1.0), std::invalid_argument);
  EXPECT_THROW(rk4_coefficients(NAN), std::invalid_argument);
}

TEST(StagedRk4, TimeIsStepsTimesStep) {
  staged_rk4 serial(two_mass_model{}, 1e-3);
  serial.run(1000);
  EXPECT_EQ(serial.steps_taken(), 1000U);
  EXPECT_EQ(serial.time(), 1000.0 * 1e-3);
}

}  // namespace
