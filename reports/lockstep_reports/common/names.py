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
