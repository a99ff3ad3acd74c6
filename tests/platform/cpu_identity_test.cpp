// The CPU's name (platform/cpu_identity.hpp) from /proc/cpuinfo texts: an x86
// guest's (tests/fixtures/cpuinfo/x86_64-xeon.txt, this project's development
// VM), and arm64 texts in the format Linux prints there (no model name; each
// CPU's MIDR fields): an AWS Graviton2-like Neoverse N1, a part no table
// names, and a big.LITTLE board (4 Cortex-A55 + 4 Cortex-A76, as an RK3588).
#include "platform/cpu_identity.hpp"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>

namespace {

using lockstep::platform::arm_core_name;
using lockstep::platform::cpu_model_of_cpuinfo;

std::string fixture(const std::string& name) {
  std::ifstream file(std::string(LOCKSTEP_SOURCE_DIR) + "/tests/fixtures/cpuinfo/" + name);
  std::ostringstream text;
  text << file.rdbuf();
  return text.str();
}

TEST(CpuIdentity, X86NamesTheModelNameLine) {
  EXPECT_EQ(cpu_model_of_cpuinfo(fixture("x86_64-xeon.txt")), "Intel(R) Xeon(R) Processor");
}

TEST(CpuIdentity, Arm64NamesTheCoreFromItsMidr) {
  EXPECT_EQ(cpu_model_of_cpuinfo(fixture("arm64-neoverse-n1.txt")), "Arm Neoverse N1");
}

TEST(CpuIdentity, AnUnknownPartIsNamedByItsNumbers) {
  EXPECT_EQ(cpu_model_of_cpuinfo(fixture("arm64-unknown-part.txt")), "implementer 0x41 part 0xd99");
}

TEST(CpuIdentity, BigLittleNamesEveryKindWithItsCount) {
  EXPECT_EQ(cpu_model_of_cpuinfo(fixture("arm64-big-little.txt")), "4 x Arm Cortex-A55 + 4 x Arm Cortex-A76");
}

// So that two different ARM machines have two fingerprints.
TEST(CpuIdentity, DifferentCoresGetDifferentNames) {
  EXPECT_EQ(arm_core_name(0x41, 0xd40), "Arm Neoverse V1");  // AWS Graviton3
  EXPECT_EQ(arm_core_name(0x41, 0xd4f), "Arm Neoverse V2");  // Nvidia Grace, AWS Graviton4
  EXPECT_EQ(arm_core_name(0x41, 0xd49), "Arm Neoverse N2");
  EXPECT_EQ(arm_core_name(0x46, 0x001), "Fujitsu A64FX");
  EXPECT_EQ(arm_core_name(0x61, 0x023), "Apple M1 Firestorm");
  EXPECT_EQ(arm_core_name(0xc0, 0xac3), "Ampere Ampere-1");
  EXPECT_EQ(arm_core_name(0x48, 0xd01), "HiSilicon TSV110 (Kunpeng 920)");
  EXPECT_EQ(arm_core_name(0x51, 0x001), "Qualcomm Oryon X1");
  // An implementer the table knows, with a part it does not; and neither.
  EXPECT_EQ(arm_core_name(0x61, 0x099), "implementer 0x61 part 0x099");
  EXPECT_EQ(arm_core_name(0x99, 0x001), "implementer 0x99 part 0x001");
}

TEST(CpuIdentity, NeitherModelNameNorMidrIsUnavailable) {
  EXPECT_EQ(cpu_model_of_cpuinfo(""), "unavailable");
  EXPECT_EQ(cpu_model_of_cpuinfo("processor\t: 0\nBogoMIPS\t: 50.00\n"), "unavailable");
  // An implementer without its part names nothing.
  EXPECT_EQ(cpu_model_of_cpuinfo("processor\t: 0\nCPU implementer\t: 0x41\n"), "unavailable");
}

TEST(CpuIdentity, ThisMachineHasAName) {
  const std::string name = lockstep::platform::cpu_model();
  EXPECT_FALSE(name.empty());
#if defined(__x86_64__) || defined(__aarch64__)
  EXPECT_NE(name, "unavailable") << "/proc/cpuinfo names no CPU here";
#endif
}

}  // namespace
