"""What lockstep's result files hold that the tools read: one place for each fact about the format.

The readers (inputs.py and the reader of each kind) check every field named here
when they read a file (type and range), and the tools read nothing else: an
unknown field is ignored, whatever it holds. compare and report take their
names and headings from here.
"""
from __future__ import annotations

from . import statistics

# ---------------------------------------------------------------- ranges

# A measured duration lies between these (ns): shorter than a picosecond or
# longer than about eleven days is not a measurement but a damaged file. The
# tools divide by durations, so the lower bound also keeps every ratio finite.
SHORTEST_NS = 1e-3
LONGEST_NS = 1e15
# A count, a rate or a ratio (context switches per kstep, x serial) lies in [0, LARGEST_AMOUNT].
LARGEST_AMOUNT = 1e15
# CPU numbers (c2c pairs) lie below this.
CPU_LIMIT = 1 << 20
# A measured ratio (lockstep_pairs) lies in [SMALLEST_RATIO, LARGEST_AMOUNT]: positive, and finite when inverted.
SMALLEST_RATIO = 1e-9
# A noise band as a fraction (lockstep_pairs[].noise: 0.05 is 5 %) lies in [0, LARGEST_NOISE].
LARGEST_NOISE = 10.0
# The pace modes' shares of the run may add up to a little more than 1 where the writer rounded each.
SHARE_SLACK = 0.01

# What a table or a context value says where a value is missing or not a number.
UNAVAILABLE = "unavailable"

# ---------------------------------------------------------------- Google Benchmark JSON (`lockstep run`)

# The schema versions this reader was written against (Google Benchmark 1.7
# writes none, 1.8 and later write "json_schema_version": 1; lockstep's own in
# CMakeLists.txt, LOCKSTEP_RESULT_SCHEMA).
KNOWN_GB_JSON_SCHEMA = 1
KNOWN_LOCKSTEP_SCHEMA = 2
# From this lockstep schema on, a `lockstep run` entry's real_time and cpu_time are per unit (the RK4 step,
# the barrier episode): real_time equals its UNIT_COUNTERS value, cpu_time is participant 0's thread CPU
# time per unit (bench/run/team_driver.hpp, before measure_entry). Before it, both were per batch of units.
PER_UNIT_TIMES_SCHEMA = 2

TIME_UNIT_NS = {"ns": 1.0, "us": 1e3, "ms": 1e6, "s": 1e9}

# The aggregates the tools read (a benchmark with no repetitions is read from them).
READ_AGGREGATES = ("median", "mean")

# The per-unit time counters of lockstep's entries, in the order they are looked
# for: ns_per_step (rk4 entries, docs/names-and-counters.md) and ns_per_episode
# (the bare barrier entries). Both time a batch of units per Google Benchmark
# iteration, and the batch size comes from each run's own probe; real_time is the
# counter from PER_UNIT_TIMES_SCHEMA on, the batch's time before, so the reader
# takes the counter, which means the same in every file.
UNIT_COUNTERS = ("ns_per_step", "ns_per_episode")
# The counter that is a c2c entry's measurement (its iteration time includes thread start-up).
C2C_COUNTER = "one_way_ns"
# Mean time in one stage sync, less one clock reading's cost: a small negative value is an
# honest measurement of a sync that costs less than the clock's own noise.
SYNC_COUNTER = "sync_ns_per_stage"
# Derived by `lockstep run` against its in-run calibrations (vs_c2c from SYNC_COUNTER, so it may be negative too).
VS_SERIAL_COUNTER = "vs_serial"
VS_C2C_COUNTER = "vs_c2c"
# Counters shown beside the time (when present), with short headings.
COUNTERS_SHOWN = (
    ("csw_vol_per_kstep", "csw vol/kstep"),
    ("csw_invol_per_kstep", "csw invol/kstep"),
    ("migrations_per_kstep", "migr/kstep"),
    ("futex_waits_per_step", "futex/step"),
    ("timeouts", "timeouts"),
    # `lockstep mpi`'s exchange entries: the tail of the per-stage exchange latency and of the arrival skew.
    ("stage_p99_ns", "stage p99 ns"),
    ("skew_p99_ns", "skew p99 ns"),
)
# `lockstep mpi`'s ping-pong entries: the median one-way time (their real_time is the OSU-style mean).
PINGPONG_P50_COUNTER = "one_way_p50_ns"
# The CPU time every participant's thread burned per unit, summed over the team (team_driver.hpp's thread CPU
# clocks), in the order of UNIT_COUNTERS: team CPU / unit time is the CPUs the team kept busy. A time, but it
# may be 0 (no clock tick), so it is read as an amount. A file written before it has none.
TEAM_CPU_COUNTERS = ("team_cpu_ns_per_step", "team_cpu_ns_per_episode")
# An rk4 entry's step split in three (per participant, adding up to about ns_per_step): computing its stages,
# waiting for the others to arrive, and the release (from the latest awaited arrival to the departure), with the
# words the report gives them. The release may read slightly negative, as sync_ns_per_stage may. The writer
# omits the three from a repetition with too few split syncs, so one repetition of an entry may have them and
# the next not: they are not READ_COUNTERS (whose presence must agree across repetitions) but taken by the
# report alone from the checked file (report.step_split_values). A file written before the split has none.
STEP_SPLIT_COUNTERS = (("compute_ns_per_step", "compute"), ("waiting_ns_per_step", "waiting for the others"),
                       ("release_ns_per_step", "release"))
# Every counter the tools read, by what it may hold; all other counters are ignored.
DURATION_COUNTERS = UNIT_COUNTERS + (C2C_COUNTER, PINGPONG_P50_COUNTER)  # ns, in [SHORTEST_NS, LONGEST_NS]
SIGNED_COUNTERS = (SYNC_COUNTER, VS_C2C_COUNTER)  # finite, |value| <= LONGEST_NS
AMOUNT_COUNTERS = (tuple(name for name, _ in COUNTERS_SHOWN) + (VS_SERIAL_COUNTER,)
                   + TEAM_CPU_COUNTERS)  # in [0, LARGEST_AMOUNT]
READ_COUNTERS = DURATION_COUNTERS + SIGNED_COUNTERS + AMOUNT_COUNTERS
# Read counters the writer may omit from one repetition and keep in the next: sync_ns_per_stage (and vs_c2c,
# derived from it) when the repetition's sampled steps timed no stage sync (bench/run/rk4_entries.cpp).
# A repetition without one is read without it; every other read counter must agree across repetitions.
PER_REPETITION_COUNTERS = (SYNC_COUNTER, VS_C2C_COUNTER)

# ---------------------------------------------------------------- the pace trace and the pairs (docs/pace.md)

# A cloud VM changes pace for seconds at a time; `lockstep run` records a pace trace between blocks of
# measurement, tags every repetition with the pace around it, and measures each ratio it prints as a pair.
# All of it is an addition: a file without these keys was written before it and reads as before.
PACE_KEY = "lockstep_pace"  # top level: {reference, cpus, readings, modes, changes, summary}
PAIRS_KEY = "lockstep_pairs"  # top level: the paired ratios, one object per ratio the summary prints
SCALING_KEY = "lockstep_scaling"  # top level (run --scaling): {pin, counter, threads, points, best, c2c_one_way_ns}
# top level: the run's answer (bench/run/answer.hpp): {lines, recommendations (its choices), collapsed, ...}; a
# file written before it has none and reads as before, and one written before the key had its name held the answer
# as lockstep_headline, which reads the same.
ANSWER_KEY = "lockstep_answer"
OLDER_ANSWER_KEY = "lockstep_headline"
ANSWER_KEYS = (ANSWER_KEY, OLDER_ANSWER_KEY)
# How a choice was made (the answer's recommendations[].basis).
CHOICE_BASES = ("paired", "medians")
# In each benchmark entry of a run file since the typed entry: its spec as values (names.EntrySpec).
ENTRY_KEY = "lockstep_entry"
# top level (run --crossover): {crossovers, ceilings, lines, budget_s, ...}
CROSSOVER_KEY = "lockstep_crossover"
# What the run derived for the tools (derived_reader.py), each at the top level but the last (inside PACE_KEY).
LAYOUTS_KEY = "lockstep_layouts"
PLANNED_KEY = "lockstep_planned_pairs"
RANKINGS_KEY = "lockstep_rankings"
MODEL_KEY = "lockstep_model"
MODE_MEDIANS_KEY = "entry_medians"
SCALING_COUNTERS = ("sync_ns_per_stage", "ns_per_step")
# Per-repetition counters (iteration rows only; an aggregate's median or mean of a mode index means nothing).
PACE_C2C_COUNTER = "pace_c2c_ns"  # ns; NaN on a machine of one CPU (no pair to measure)
PACE_SERIAL_COUNTER = "pace_serial_ns"  # ns
PACE_MODE_COUNTER = "pace_mode"  # an index into lockstep_pace.modes, or OUTLIER_MODE
PACE_COUNTERS = (PACE_C2C_COUNTER, PACE_SERIAL_COUNTER, PACE_MODE_COUNTER)
# The mode of a reading that belongs to no mode, of a repetition whose readings before and after disagree
# (it straddles a change), of a pair whose mode is unknown.
OUTLIER_MODE = -1
# Keys that hold a mode: -1 is a valid value of each (the fuzz test may turn a 0 into a valid -1).
MODE_KEYS = ("mode", "modes", PACE_MODE_COUNTER)
# What a pair compares (lockstep_pairs[].comparison) and what it concluded (verdict: statistics.verdict's words;
# files written before "unsure" call a straddling interval "within noise").
PAIR_COMPARISONS = ("false_sharing", "migration", "against_best_other", "overhead")
PAIR_VERDICTS = statistics.VERDICTS

# ---------------------------------------------------------------- the context of a run file

# The in-run calibrations lockstep writes into the context: text, a number of ns or "unavailable".
C2C_CONTEXT = "c2c_one_way_ns"
SERIAL_CONTEXT = "serial_step_ns"
CALIBRATION_CONTEXT = (C2C_CONTEXT, SERIAL_CONTEXT)
# Context keys that identify a machine and a build, in the order shown.
FINGERPRINT_KEYS = (
    "cpu_model", "topology", "hypervisor", "kernel", "num_cpus", "mhz_per_cpu", "host_name",
    "compiler", "cxx_flags", "build_type", "lockstep_version", "lockstep_schema", "git_revision",
    "benchmark_version", "hwloc_version", "boost_version", C2C_CONTEXT, SERIAL_CONTEXT,
    "oversubscribed_note", "lockstep_order", "date",
)
# Keys whose difference means "another machine" rather than "another run".
MACHINE_KEYS = ("cpu_model", "topology", "hypervisor", "kernel", "num_cpus")
# The build a file's times measure (comparability.py: a Debug build's times are not its machine's).
BUILD_TYPE_CONTEXT = "build_type"
CXX_FLAGS_CONTEXT = "cxx_flags"
REVISION_CONTEXT = "git_revision"
# git_revision's suffix for a build from a tree with uncommitted changes.
DIRTY_SUFFIX = "-dirty"
# How the run measured (bench/run/matrix_run.cpp: "quick" or "default"; `lockstep mpi`: "mpi"): read beside the
# fingerprint, not shown in it.
MODE_CONTEXT = "lockstep_mode"
QUICK_MODE = "quick"
# A run of a group (`lockstep run --runs K`): its index 1..K and K; compare takes a group's runs as replicates.
RUN_INDEX_CONTEXT = "lockstep_run_index"
RUNS_CONTEXT = "lockstep_runs"
# A run's costs in seconds (bench/run/matrix_run.cpp run_matrix): measuring the matrix's repetitions, and in all.
MATRIX_SECONDS_CONTEXT = "lockstep_matrix_s"
WALL_SECONDS_CONTEXT = "lockstep_wall_s"
RUN_CONTEXT_KEYS = (MODE_CONTEXT, RUN_INDEX_CONTEXT, RUNS_CONTEXT, MATRIX_SECONDS_CONTEXT, WALL_SECONDS_CONTEXT)
# Context keys read as whole numbers from 1 that files written before they were numbers hold as text ("3").
CONTEXT_COUNTS = (RUN_INDEX_CONTEXT, RUNS_CONTEXT)
# Google Benchmark writes these as whole numbers; every other fingerprint key is text.
CONTEXT_INTEGERS = ("num_cpus", "mhz_per_cpu")
# lockstep_order's value when a run measured every entry's repetitions back to back (no --interleave).
BACK_TO_BACK_ORDER = "registration order"

# ---------------------------------------------------------------- `lockstep c2c --json`, `lockstep delay --json`

# A distribution as the C++ writes it; with count 0 every statistic is null.
DISTRIBUTION_STATISTICS = ("min", "p50", "p99", "p999", "max")
# The settings of a delay run the report shows, in this order, with the JSON type each holds
# ("integer or null" for fifo_priority: null is SCHED_OTHER).
DELAY_SETTINGS = (
    ("period_ns", "duration"), ("periods", "count"), ("duration_s", "seconds"), ("sync", "text"),
    ("layout", "text"), ("pin", "text"), ("threads", "count"), ("placement", "text"),
    ("fifo_priority", "priority"), ("mlock", "flag"),
)

# ---------------------------------------------------------------- `lockstep verify --csv`

VERIFY_HEADER = ("t", "x1", "x2")
# The model's displacements stay within its initial amplitude (x(0) = (2, -3)); far beyond is a damaged file.
LARGEST_DISPLACEMENT = 1e6
