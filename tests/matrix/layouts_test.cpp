// The layouts at run time: every slot has its own address, the blocks the
// static_asserts promise hold for the sizes the matrix runs (not only the
// paper's case), and owners never share a block where a layout says so
// (kWriterIsolation). The per-layout checks run over every layout of the
// registry (layouts/registry.hpp), chosen by the layout's kind: a new layout
// is checked by joining the registry.
#include <cstdint>
#include <functional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "layouts/registry.hpp"

namespace lockstep::layouts {
namespace {

std::uintptr_t address(const double& value) { return reinterpret_cast<std::uintptr_t>(&value); }

// Every (slot, equation) of a shared layout: its address and its owner.
struct placed {
  std::uintptr_t address;
  unsigned owner;
};

template <class Layout>
std::vector<placed> shared_slots_of(Layout& layout, const partition& blocks) {
  std::vector<placed> result;
  for (std::size_t equation = 0; equation < blocks.equations(); ++equation) {
    const unsigned owner = blocks.owner(equation);
    result.push_back({address(layout.state(0, equation)), owner});
    result.push_back({address(layout.state(1, equation)), owner});
    for (unsigned stage = 0; stage < kSharedStageSlots; ++stage)
      result.push_back({address(layout.stage(stage, equation)), owner});
  }
  return result;
}

bool owners_share(const std::vector<placed>& slots, std::size_t unit) {
  for (const placed& a : slots)
    for (const placed& b : slots)
      if (a.owner != b.owner && a.address / unit == b.address / unit) return true;
  return false;
}

std::size_t distinct(const std::vector<placed>& slots) {
  std::set<std::uintptr_t> addresses;
  for (const placed& slot : slots) addresses.insert(slot.address);
  return addresses.size();
}

struct shape {
  std::size_t equations;
  unsigned participants;
  std::size_t grain = 1;  // 2: a chain's masses (layouts/partition.hpp)
};
constexpr shape kShapes[] = {{4, 1}, {4, 2}, {4, 4}, {6, 4}, {10, 3}, {16, 4}, {10, 2, 2}, {16, 3, 2}, {66, 4, 2}};

TEST(Partition, BlocksCoverEveryEquationOnceInOrder) {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants, each.grain);
    std::size_t next = 0;
    for (unsigned participant = 0; participant < each.participants; ++participant) {
      const equation_block block = blocks.block(participant);
      EXPECT_EQ(block.first, next);
      EXPECT_GE(block.size(), 1U);
      EXPECT_LE(block.size(), blocks.largest_block());
      for (std::size_t equation = block.first; equation < block.last; ++equation)
        EXPECT_EQ(blocks.owner(equation), participant);
      next = block.last;
    }
    EXPECT_EQ(next, each.equations);
  }
}

// A grain of 2 (a chain's masses): blocks of whole units while there are at
// least as many units as participants, in order, every equation once, sizes
// one unit apart at most; single equations beyond.
TEST(Partition, CutsInWholeGrainsWhenThereAreEnough) {
  for (std::size_t units : {1U, 2U, 3U, 5U, 8U, 33U})
    for (unsigned participants = 1; participants <= 2 * units; ++participants) {
      const partition blocks(2 * units, participants, 2);
      EXPECT_EQ(blocks.grain(), 2U);
      EXPECT_EQ(blocks.by_grain(), participants <= units) << units << " units on " << participants;
      const std::size_t unit = blocks.by_grain() ? 2 : 1;
      std::size_t next = 0;
      for (unsigned participant = 0; participant < participants; ++participant) {
        const equation_block block = blocks.block(participant);
        EXPECT_EQ(block.first, next);
        EXPECT_EQ(block.first % unit, 0U);
        EXPECT_EQ(block.size() % unit, 0U);
        EXPECT_GE(block.size(), unit);
        EXPECT_LE(block.size(), blocks.largest_block());
        EXPECT_LE(blocks.largest_block() - block.size(), unit) << "blocks differ by one unit at most";
        for (std::size_t equation = block.first; equation < block.last; ++equation)
          EXPECT_EQ(blocks.owner(equation), participant);
        next = block.last;
      }
      EXPECT_EQ(next, 2 * units);
    }
  EXPECT_EQ(partition(4, 2, 1).block(0).last, 2U) << "a grain of 1 is the equation split";
}

TEST(Partition, RejectsAGrainThatDoesNotDivideTheEquations) {
  EXPECT_THROW(partition(5, 2, 2), partition_error);
  EXPECT_THROW(partition(4, 2, 0), partition_error);
}

TEST(Partition, RejectsMoreThreadsThanEquationsWithAReason) {
  EXPECT_THROW(partition(4, 0), partition_error);
  try {
    partition(4, 5);
    FAIL() << "5 threads over 4 equations must be rejected";
  } catch (const partition_error& error) {
    EXPECT_NE(std::string(error.what()).find("every thread must own at least one equation"), std::string::npos);
  }
}

TEST(Packed, EverySlotDistinctAndContiguous) {
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants, each.grain);
    packed layout(blocks);
    const auto slots = shared_slots_of(layout, blocks);
    EXPECT_EQ(distinct(slots), kSharedSlots * each.equations);
    EXPECT_EQ(layout.bytes(), kSharedSlots * each.equations * sizeof(double)) << "packed has no padding";
    EXPECT_EQ(address(layout.state(0, 0)) % platform::kCacheLine, 0U) << "packed starts on a line boundary";
  }
}


// A shared layout: every slot distinct; the buffer starts on a line boundary
// (and on a kWriterIsolation boundary); with kWriterIsolation > 0 no two
// writers share a block of that size, with 0 some line holds two writers'
// values (the false sharing such a layout is there to measure).
template <class Layout>
void expect_shared_slots_as_declared() {
  constexpr std::size_t isolation = Layout::kWriterIsolation;
  constexpr std::size_t alignment = isolation > platform::kCacheLine ? isolation : platform::kCacheLine;
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants, each.grain);
    Layout layout(blocks);
    const auto slots = shared_slots_of(layout, blocks);
    EXPECT_EQ(distinct(slots), kSharedSlots * each.equations);
    EXPECT_EQ(address(layout.state(0, 0)) % alignment, 0U) << Layout::kName << " starts on a block boundary";
    // Each owner's block of a slot is one array (shared_slots.hpp): the step
    // addresses it through one pointer.
    for (std::size_t equation = 1; equation < each.equations; ++equation) {
      if (blocks.owner(equation) != blocks.owner(equation - 1)) continue;
      for (unsigned parity = 0; parity < 2; ++parity)
        EXPECT_EQ(address(layout.state(parity, equation)), address(layout.state(parity, equation - 1)) + sizeof(double))
            << Layout::kName << ": x of equation " << equation;
      for (unsigned stage = 0; stage < kSharedStageSlots; ++stage)
        EXPECT_EQ(address(layout.stage(stage, equation)), address(layout.stage(stage, equation - 1)) + sizeof(double))
            << Layout::kName << ": k_" << stage << " of equation " << equation;
    }
    if constexpr (isolation > 0) {
      EXPECT_FALSE(owners_share(slots, isolation))
          << Layout::kName << ": two writers share a " << isolation << "-byte block with " << each.equations
          << " equations on " << each.participants << " threads";
    } else if (each.participants > 1) {
      EXPECT_TRUE(owners_share(slots, platform::kCacheLine))
          << Layout::kName << " declares writers side by side, but none share a line with " << each.equations
          << " equations on " << each.participants << " threads";
    }
  }
}

// A private_copy layout: the board and every participant's copy of x and
// k_0..k_3 are distinct; board regions and copies are each one writer's
// blocks of kWriterIsolation bytes; no copy shares a line with the board.
template <class Layout>
void expect_private_copies_as_declared() {
  constexpr std::size_t isolation = Layout::kWriterIsolation;
  for (const shape& each : kShapes) {
    const partition blocks(each.equations, each.participants, each.grain);
    Layout layout(blocks);
    std::vector<placed> board;
    for (std::size_t equation = 0; equation < each.equations; ++equation)
      for (std::size_t slot = 0; slot < kBoardSlots; ++slot)
        board.push_back({address(layout.board(slot, equation)), blocks.owner(equation)});
    EXPECT_EQ(distinct(board), kBoardSlots * each.equations);
    for (std::size_t equation = 1; equation < each.equations; ++equation) {
      if (blocks.owner(equation) != blocks.owner(equation - 1)) continue;
      for (std::size_t slot = 0; slot < kBoardSlots; ++slot) {
        EXPECT_EQ(address(layout.board(slot, equation)), address(layout.board(slot, equation - 1)) + sizeof(double))
            << Layout::kName << ": board slot " << slot << " of equation " << equation;
      }
    }
    std::vector<placed> copies;
    for (unsigned participant = 0; participant < each.participants; ++participant) {
      for (std::size_t equation = 0; equation < each.equations; ++equation) {
        copies.push_back({address(layout.private_state(participant)[equation]), participant});
        for (unsigned stage = 0; stage < kPrivateStageValues; ++stage)
          copies.push_back({address(layout.private_stage(participant, stage)[equation]), participant});
      }
    }
    EXPECT_EQ(distinct(copies), (1 + kPrivateStageValues) * each.equations * each.participants);
    if constexpr (isolation > 0) {
      EXPECT_FALSE(owners_share(board, isolation)) << Layout::kName << ": board blocks are one writer's each";
      EXPECT_FALSE(owners_share(copies, isolation)) << Layout::kName << ": private copies never share a block";
    }
    for (const placed& copy : copies)
      for (const placed& slot : board)
        EXPECT_NE(copy.address / platform::kCacheLine, slot.address / platform::kCacheLine)
            << Layout::kName << ": a private copy shares a line with the board";
  }
}

// A test whose body is a closure, registered per layout of the registry.
class layout_test : public ::testing::Test {
 public:
  explicit layout_test(std::function<void()> body) : body_(std::move(body)) {}
  void TestBody() override { body_(); }

 private:
  std::function<void()> body_;
};

// SharedLayout.<name> or PrivateCopyLayout.<name>, by the layout's kind.
const bool registered = [] {
  for_each_layout([]<class Layout>() {
    std::function<void()> body;
    const char* suite = nullptr;
    if constexpr (Layout::kKind == layout_kind::shared) {
      suite = "SharedLayout";
      body = expect_shared_slots_as_declared<Layout>;
    } else {
      suite = "PrivateCopyLayout";
      body = expect_private_copies_as_declared<Layout>;
    }
    ::testing::RegisterTest(suite, std::string(Layout::kName).c_str(), nullptr, nullptr, __FILE__, __LINE__,
                            [body]() -> ::testing::Test* { return new layout_test(body); });
  });
  return true;
}();

// The registry holds the layouts of docs/design.md with the facts it states.
TEST(LayoutRegistry, ListsEveryLayoutOfTheDesignWithItsFacts) {
  struct design_facts {
    std::string_view name;
    layout_kind kind;
    std::size_t writer_isolation;
  };
  constexpr design_facts kDesign[] = {
      {"packed", layout_kind::shared, 0},
      {"padded64", layout_kind::shared, 64},
      {"padded128", layout_kind::shared, 128},
      {"per_thread", layout_kind::private_copy, 64},
  };
  for (const design_facts& design : kDesign) {
    const layout_info* info = find_layout(design.name);
    ASSERT_NE(info, nullptr) << design.name << " is in docs/design.md but not in the registry";
    EXPECT_EQ(info->kind, design.kind) << design.name;
    EXPECT_EQ(info->writer_isolation, design.writer_isolation) << design.name;
  }
  EXPECT_EQ(find_layout("no_such_layout"), nullptr);
}

TEST(LayoutRegistry, NamesOnceAndOneLineDescriptions) {
  std::size_t visited = 0;
  for_each_layout([&]<class Layout>() {
    static_assert(registered_layout<Layout>);
    EXPECT_EQ(info_of<Layout>().name, all_layout_info[visited].name) << "for_each_layout follows all_layout_info";
    ++visited;
  });
  EXPECT_EQ(visited, all_layout_info.size());
  std::set<std::string_view> listed;
  for (const layout_info& info : all_layout_info) {
    EXPECT_TRUE(listed.insert(info.name).second) << info.name << " listed twice";
    EXPECT_FALSE(info.name.empty());
    EXPECT_FALSE(info.description.empty()) << info.name;
    EXPECT_EQ(info.description.find('\n'), std::string_view::npos) << info.name << ": one line";
  }
}

// The writer-isolation facts are compile-time strides; the machine's line is
// read at run time. On a 64-byte line every isolating layout holds; on a
// wider one (Apple M-series: 128 bytes; Fujitsu A64FX: 256) the narrower
// layouts are named as not isolating, with what they then measure.
TEST(LayoutRegistry, WriterIsolationAgainstTheMachinesLine) {
  const layout_info& packed_info = *find_layout("packed");
  const layout_info& padded64_info = *find_layout("padded64");
  const layout_info& padded128_info = *find_layout("padded128");
  const layout_info& per_thread_info = *find_layout("per_thread");
  EXPECT_FALSE(isolates_writers(packed_info, 64)) << "packed shares lines on purpose";
  EXPECT_TRUE(isolates_writers(padded64_info, 64));
  EXPECT_TRUE(isolates_writers(per_thread_info, 64));
  EXPECT_FALSE(isolates_writers(padded64_info, 128));
  EXPECT_TRUE(isolates_writers(padded128_info, 128));
  EXPECT_FALSE(isolates_writers(padded128_info, 256));

  const std::string holds = writer_isolation_note(64);
  EXPECT_EQ(holds.rfind("holds", 0), 0U) << holds;
  EXPECT_NE(holds.find("64-byte"), std::string::npos) << holds;

  const std::string apple = writer_isolation_note(128);
  EXPECT_EQ(apple.rfind("does not hold for padded64 (64 bytes), per_thread (64 bytes):", 0), 0U) << apple;
  EXPECT_EQ(apple.find("padded128"), std::string::npos) << apple;
  EXPECT_NE(apple.find("128-byte cache line"), std::string::npos) << apple;

  const std::string a64fx = writer_isolation_note(256);
  EXPECT_EQ(a64fx.rfind("does not hold for padded64 (64 bytes), padded128 (128 bytes), per_thread (64 bytes):", 0), 0U)
      << a64fx << " (packed claims no isolation to lose)";
}

// A layout lacking one trait is not a registered_layout (the registry then
// fails to compile, naming the trait).
struct lacks_writer_isolation {
  static constexpr std::string_view kName = "lacks_writer_isolation";
  static constexpr std::string_view kDescription = "a shared layout that forgot one trait";
  static constexpr layout_kind kKind = layout_kind::shared;
  explicit lacks_writer_isolation(const partition& /*blocks*/) {}
  double& state(unsigned /*parity*/, std::size_t /*equation*/) noexcept { return value; }
  double& stage(unsigned /*stage*/, std::size_t /*equation*/) noexcept { return value; }
  double value = 0;
};
static_assert(shared_slots_layout<lacks_writer_isolation> &&
              !layout_declares_writer_isolation<lacks_writer_isolation> &&
              !registered_layout<lacks_writer_isolation>);

}  // namespace
}  // namespace lockstep::layouts
