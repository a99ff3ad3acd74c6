"""Benchmark names as lockstep writes them: `key:value` segments after a family.

    rk4/sync:<primitive>/layout:<layout>/pin:compact/threads:4
    rk4/model:chain8/sync:<primitive>/layout:<layout>/pin:compact/threads:16   (an s-mass chain; no model: the
                                                                                paper's two masses)
    barrier/sync:<primitive>/pin:compact/threads:2
    rk4/serial
    c2c/pin:compact/threads:2
    mpi/exchange:shm_window/sync:<primitive>/ranks:4/hosts:1      (`lockstep mpi`)
    mpi/pingpong/ranks:2/hosts:1

Two entries are the same benchmark when their family and identity segments are
equal, whatever their order. Segments that Google Benchmark appends to describe
how it ran (min_time:, min_warmup_time:, repeats:, iterations:, real_time,
process_time, manual_time) are not part of the identity: a run with 10
repetitions still matches one with 6.

A `lockstep run` file written since the typed entry carries each entry's spec as values beside its name
("lockstep_entry": EntrySpec), and its identity is read from them (EntrySpec.key), never from the name; the same
key the name gives, so that an older file's entry matches a newer file's. parse_name and spec_of (the spec a name
implies) read the names of files written before it, and of `lockstep mpi` files, which have no spec.
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

# Google Benchmark's run-configuration segments (benchmark_register.cc adds them to names).
RUN_CONFIGURATION_KEYS = {"min_time", "min_warmup_time", "repeats", "iterations"}
RUN_CONFIGURATION_WORDS = {"real_time", "process_time", "manual_time"}
# The order in which lockstep's own segments are shown.
SEGMENT_ORDER = ("pingpong", "model", "exchange", "sync", "layout", "pin", "threads", "ranks", "hosts")


@dataclass(frozen=True, order=True)
class BenchmarkKey:
    family: str
    segments: tuple[tuple[str, str], ...]  # sorted (key, value); value "" for a bare word

    def get(self, key: str, default: str | None = None) -> str | None:
        for segment_key, value in self.segments:
            if segment_key == key:
                return value
        return default

    @property
    def display(self) -> str:
        def rank(segment):
            key = segment[0]
            return (SEGMENT_ORDER.index(key) if key in SEGMENT_ORDER else len(SEGMENT_ORDER), key)

        parts = [self.family]
        for key, value in sorted(self.segments, key=rank):
            parts.append(f"{key}:{value}" if value else key)
        return "/".join(parts)

    @property
    def threads(self) -> int | None:
        value = self.get("threads")
        try:
            return int(value) if value is not None else None
        except ValueError:
            return None

    def sort_key(self):
        """Families, then sync, layout, pin, threads numerically: the order of every table."""
        threads = self.threads
        return (self.family, self.get("sync") or "", self.get("layout") or "", self.get("pin") or "",
                threads if threads is not None else -1, self.display)

    def without(self, *keys: str) -> "BenchmarkKey":
        return BenchmarkKey(self.family, tuple(s for s in self.segments if s[0] not in keys))

    def replaced(self, key: str, value: str) -> "BenchmarkKey":
        kept = [s for s in self.segments if s[0] != key] + [(key, value)]
        return BenchmarkKey(self.family, tuple(sorted(kept)))


# What an entry's time counts (EntrySpec.unit) and the counter that holds it per unit (fields.UNIT_COUNTERS); a
# core-to-core entry's time is its one-way latency, read by its one_way_ns counter where compare needs it.
UNITS = ("step", "episode", "one_way")
UNIT_COUNTER = {"step": "ns_per_step", "episode": "ns_per_episode"}


@dataclass(frozen=True)
class EntrySpec:
    """An entry's spec as `lockstep run` writes it ("lockstep_entry", docs/schemas/run.schema.json; the writer's
    entry_spec): its kind ("rk4", "serial", "barrier", "c2c", "overhead"), primitive and layout (None where the
    kind has none), placement (None for serial), threads (1 for serial), model (the name's model segment, "" for
    the paper's two-mass system) and masses (0 for it), the overhead pair's side (accounting; True elsewhere), and
    what its time counts (unit: UNITS)."""

    kind: str
    sync: str | None
    layout: str | None
    pin: str | None
    threads: int
    model: str
    masses: int
    accounting: bool
    unit: str

    @property
    def key(self) -> BenchmarkKey:
        """The entry's identity: the key parse_name gives its name (rk4/model:chain8/serial, overhead/accounting:on/...,
        c2c/pin:compact/threads:2), made from the values."""
        segments = [("model", self.model)] if self.model else []
        if self.kind == "serial":
            segments.append(("serial", ""))
        if self.kind == "overhead":
            segments.append(("accounting", "on" if self.accounting else "off"))
        segments += [(name, value) for name, value in (("sync", self.sync), ("layout", self.layout)) if value]
        if self.kind != "serial":
            segments += [("pin", self.pin or ""), ("threads", str(self.threads))]
        return BenchmarkKey("rk4" if self.kind == "serial" else self.kind, tuple(sorted(segments)))

    @property
    def unit_counter(self) -> str | None:
        """The counter holding its time per unit (UNIT_COUNTER); None for a core-to-core entry."""
        return UNIT_COUNTER.get(self.unit)


def entry_spec(values: dict) -> EntrySpec:
    """An EntrySpec from a file's "lockstep_entry" (its schema checked)."""
    return EntrySpec(values["kind"], values["sync"], values["layout"], values["pin"], values["threads"],
                     values["model"], values["masses"], values["accounting"], values["unit"])


# The kind of each family a name starts with, and what its time counts, for spec_of (files before the typed entry).
_FAMILY_UNITS = {"rk4": "step", "barrier": "episode", "c2c": "one_way", "overhead": "step"}


def spec_of(key: BenchmarkKey) -> EntrySpec | None:
    """The spec a name implies, for a file written before the typed entry: None for a name of no `lockstep run`
    kind (a `lockstep mpi` entry)."""
    if key.family not in _FAMILY_UNITS:
        return None
    model = key.get("model") or ""
    kind = "serial" if key.family == "rk4" and key.get("serial") == "" else key.family
    threads = key.threads if kind != "serial" and key.threads is not None else 1
    masses = int(model[len("chain"):]) if model.startswith("chain") and model[len("chain"):].isdigit() else 0
    return EntrySpec(kind, key.get("sync"), key.get("layout"), None if kind == "serial" else key.get("pin"), threads,
                     model, masses, key.get("accounting") != "off", _FAMILY_UNITS[key.family])


@functools.lru_cache(maxsize=4096)  # a file names each benchmark once per repetition and aggregate
def parse_name(name: str) -> BenchmarkKey:
    parts = [part for part in name.split("/") if part != ""]
    if not parts:
        return BenchmarkKey("", ())
    family, segments = parts[0], []
    for part in parts[1:]:
        key, colon, value = part.partition(":")
        if colon:
            if key in RUN_CONFIGURATION_KEYS:
                continue
            segments.append((key, value))
        elif part not in RUN_CONFIGURATION_WORDS:
            segments.append((part, ""))
    return BenchmarkKey(family, tuple(sorted(segments)))
