#pragma once
// The CPU's name, from what the architecture offers in /proc/cpuinfo, for the
// result's cpu_model (a fingerprint key: two machines whose names differ are
// two machines).
//
//  * x86 (and any kernel that prints one): the "model name" line, as the CPU
//    states it ("AMD EPYC 7232P 8-Core Processor").
//  * arm64: the kernel prints no model name, only each CPU's MIDR fields:
//    "CPU implementer" (0x41 = Arm) and "CPU part" (0xd0c = Neoverse N1). The
//    name comes from the table in platform/cpu_identity.cpp (the numbers are
//    those of the Linux kernel's arch/arm64/include/asm/cputype.h); a pair
//    the table lacks is named by its numbers ("implementer 0x41 part 0xd99"),
//    so two different cores still differ. A heterogeneous machine
//    (big.LITTLE, Apple's P and E cores) names every kind with its count of
//    CPUs, in the order they appear ("4 x Arm Cortex-A55 + 4 x Arm
//    Cortex-A76"). Cloud parts name the core they are built on: AWS
//    Graviton2 is "Arm Neoverse N1", Graviton3 "Arm Neoverse V1", Graviton4
//    and Nvidia Grace "Arm Neoverse V2", Ampere Altra "Arm Neoverse N1"; the
//    topology and the CPU count beside it in the fingerprint tell such
//    machines apart.
// When a text carries both (no kernel does today), the MIDR names the core
// more precisely and wins. Neither: "unavailable".
#include <string>
#include <string_view>

namespace lockstep::platform {

// The name of an arm64 core from its MIDR implementer and part number
// (a named pair, or "implementer 0x41 part 0xd99").
std::string arm_core_name(unsigned implementer, unsigned part);

// The CPU's name from the text of /proc/cpuinfo, as the header describes.
std::string cpu_model_of_cpuinfo(std::string_view cpuinfo);

// The name of this machine's CPU (/proc/cpuinfo), or "unavailable".
std::string cpu_model();

}  // namespace lockstep::platform
