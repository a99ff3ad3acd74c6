"""The run's answer and its crossover sweep as the tools hold them (answer_reader.py reads them): the answer's
lines, choices, collapsed entries, answer first and probes; the sweep's series, points and ceilings. "Answer" is the
one name of the run's answer here (the file's section is lockstep_answer, lockstep_headline before it); a "choice" is
the combination it names for one thread count and placement; a crossover's "leader" is a series the sweep follows."""
from __future__ import annotations

from dataclasses import dataclass

from ..common.names import BenchmarkKey


@dataclass(frozen=True)
class PairedRatio:
    """A ratio measured as a pair, with its interval and verdict (fields.PAIR_VERDICTS' words as the file wrote
    them): a false-sharing probe or pattern (an access's time on one shared line over its time on lines apart;
    `name` the pattern, in the answer's words where the file has them). median None: the file says it could not
    be measured."""

    name: str
    median: float | None
    ci_low: float | None
    ci_high: float | None
    verdict: str | None


@dataclass(frozen=True)
class Migration:
    """the answer's migration_probe: the medians of a forced move between two CPUs and of refilling the
    cache after it."""

    move_ns: float
    refill_ns: float
    cpus: str


@dataclass(frozen=True)
class CrossoverPoint:
    """One size of a crossover series (lockstep_crossover.crossovers[].points[]), as the run wrote it: the chain of
    `masses` masses, its serial step and the series' parallel step (medians of the pairs), the paired speedup
    serial / parallel with its interval and verdict, the pairs it stands on, and the model's step (serial / T +
    the stages' syncs; None: the file has none there) with the measured step over it. `failure` non-empty: no
    speedup was measured at this size, and why (its numbers are then the writer's zeros, never drawn)."""

    masses: int
    serial_ns: float
    parallel_ns: float
    speedup: float
    ci_low: float
    ci_high: float
    verdict: str | None
    pairs: int
    pairs_set_aside: int
    model_ns: float | None
    measured_over_model: float | None
    failure: str
    of_ceiling: float | None = None  # its speedup over the ceiling's at this size (None: not measured, or no ceiling)

    @property
    def measured(self) -> bool:
        """A speedup was measured here (bench/run/crossover.hpp, crossover_sweep_point::measured)."""
        return not self.failure and self.pairs > 0


@dataclass(frozen=True)
class CeilingPoint:
    """One size of the machine's ceiling (lockstep_crossover.ceilings[].points[]): the serial step paired with the
    chain's blocks stepped at once with no exchange and no sync (blocks_ns), the speedup serial / blocks with its
    interval; `failure` non-empty: not measured here."""

    masses: int
    serial_ns: float
    blocks_ns: float
    speedup: float
    ci_low: float
    ci_high: float
    pairs: int
    pairs_set_aside: int
    failure: str

    @property
    def measured(self) -> bool:
        return not self.failure and self.pairs > 0


@dataclass(frozen=True)
class Ceiling:
    """The machine's ceiling at one thread count and placement (bench/run/crossover.hpp, crossover_ceiling): the
    most an even split of the chain reaches there, per size."""

    threads: int
    pin: str
    points: tuple[CeilingPoint, ...] = ()
    quoted_masses: int | None = None  # the size the run's ceiling line quotes (None: nothing measured)

    def quoted(self) -> CeilingPoint | None:
        """The point the run's ceiling line quotes, as written."""
        return next((point for point in self.points if point.masses == self.quoted_masses and point.measured), None)


@dataclass(frozen=True)
class Crossover:
    """One crossover of lockstep_crossover: at this thread count (and placement, when the file gives one) and
    with this primitive, the model size (masses) from which the parallel step beats the serial one, with its
    interval; masses None: no crossover within what the run swept. Where the file has them (lockstep run writes
    them; a file in the earlier shape has none): the layout, whether the primitive is the run's leader, the
    status (CROSSOVER_STATUSES), the sizes that confirmed or contradicted it, why the series stopped, the
    measured sync of a stage the model uses, and every point in the order written."""

    threads: int
    pin: str
    sync: str
    masses: float | None
    ci_low: float | None
    ci_high: float | None
    layout: str = ""
    leader: bool = False
    status: str = ""
    confirmed_at: float | None = None
    contradicted_at: float | None = None
    stop_reason: str = ""
    stage_sync_ns: float | None = None
    points: tuple[CrossoverPoint, ...] = ()


@dataclass(frozen=True)
class CrossoverSweep:
    """The file's lockstep_crossover: the sweep as a whole (its budget and the time it spent in seconds, the pairs it
    asked per point, why it stopped: "" where the file does not say), its lines (the answer's crossover lines, as
    lockstep run wrote them), the machine's ceilings and the series."""

    budget_s: float | None
    spent_s: float | None
    pairs_per_point: int | None
    stop_reason: str
    lines: tuple[str, ...]
    ceilings: tuple[Ceiling, ...] = ()  # none in a file written before the sweep measured them
    crossovers: tuple[Crossover, ...] = ()  # the series, in the order written


@dataclass(frozen=True)
class Choice:
    """One of the answer's choices (its "recommendations" in the file): the combination to use at one model, thread
    count and placement, as lockstep run chose it (bench/run/answer.hpp)."""

    threads: int
    pin: str
    model: str  # "": the paper's two-mass system
    entry: str  # its entry's name, as written
    entry_key: BenchmarkKey
    sync: str
    layout: str
    ns_per_step: float
    basis: str  # fields.CHOICE_BASES: "paired" (its pair with the runner-up decided) or "medians"
    # What the terminal's line says beside it, as lockstep run wrote it (None or the default: a file written
    # before the key): the repetitions' spread (half their range over the median, in %), the pace modes they
    # ran in and whether one straddled a change of pace, a stage's sync in c2c transfers, the CPUs the team
    # kept busy, whether the threads outnumbered the CPUs, the median leader (the entry first by median).
    spread_pct: float | None = None
    paces: int | None = None
    straddles_pace_change: bool = False
    vs_c2c: float | None = None
    cpus_busy: float | None = None
    oversubscribed: bool = False
    median_leader: str = ""
    # The runner-up and the baseline primitive against the choice (their step / the choice's, paired), None
    # where the run has none; tied: the pair with the runner-up is within noise or unsure, so the two are named
    # as tied (false in a file written before the key).
    runner_up: Rival | None = None
    baseline: Rival | None = None
    tied: bool = False


@dataclass(frozen=True)
class Rival:
    """Another primitive set against a choice (the file's recommendations[].runner_up, .baseline):
    its entry and primitive, and its step over the chosen one's, paired: the median ratio, its interval and
    verdict (fields.PAIR_VERDICTS: penalty, the rival is slower; gain, faster)."""

    entry: str
    entry_key: BenchmarkKey
    sync: str
    median: float
    ci_low: float
    ci_high: float
    verdict: str


@dataclass(frozen=True)
class BestChoice:
    """The answer first (the file's "answer" inside the answer's section): the best combination of the run (its
    thread count, placement and entry, its median step) and that step against the serial step of its model
    (vs_serial: the parallel step over the serial one)."""

    threads: int
    pin: str
    entry: str
    entry_key: BenchmarkKey
    ns_per_step: float
    serial_ns_per_step: float | None
    vs_serial: float | None
    # (threads, pin, ns_per_step) of the choices the run does not separate from this one (the file's answer.level:
    # their repetitions overlap and no pair compared them): a tie, said beside the best.
    level: tuple = ()


@dataclass(frozen=True)
class Answer:
    """The run's answer (the file's lockstep_answer; lockstep_headline in files written before that name): its lines
    as the terminal printed them (shown verbatim: the same fact reads the same everywhere), the choices, the entries
    that collapsed (oversubscribed and at least 100 times the best of their kind and thread count: kept out of
    rankings, ratios and colour scales), the answer first, the crossover's lines, and the known-answer probes (false
    sharing, per access pattern where the file has them, and migration; or why each was unavailable, None where the
    file says nothing). Every field has a default: Answer() is a file's without one."""

    lines: tuple[str, ...] = ()
    choices: tuple[Choice, ...] = ()
    collapsed: tuple[str, ...] = ()  # entry names as written, each once
    collapsed_keys: frozenset = frozenset()
    best: BestChoice | None = None  # None: a file written before the answer first
    # The crossover lines (per thread count swept the crossover's and the ceiling's, also among `lines`), as the run
    # wrote them; empty without `--crossover` or in a file written before the key.
    crossover: tuple[str, ...] = ()
    false_sharing: PairedRatio | None = None
    false_sharing_unavailable: str | None = None
    patterns: tuple[PairedRatio, ...] = ()
    migration: Migration | None = None
    migration_unavailable: str | None = None
