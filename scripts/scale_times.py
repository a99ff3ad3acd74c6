#!/usr/bin/python3
"""Scale the step and episode times of a `lockstep run` file (or of every run file of a directory of runs) by a
factor: a known change, to check what `lockstep compare` calls against it.

    scripts/scale_times.py FACTOR INPUT OUTPUT

INPUT is a result file or a directory of `lockstep run --runs K` (run-1.json ... run-K.json); OUTPUT the file or
directory to write (a directory is made; it must not exist). Multiplied by FACTOR: real_time, cpu_time,
ns_per_step and ns_per_episode of every rk4/ and barrier/ entry, each repetition and each aggregate but the
percentages (cv). Nothing else changes (the calibrations, c2c, the pace trace, the pairs, the answer).
Bad input: one line on stderr, exit 2, nothing written.
"""
import json
import math
import os
import sys

SCALED_FIELDS = ("real_time", "cpu_time", "ns_per_step", "ns_per_episode")
SCALED_FAMILIES = ("rk4/", "barrier/")


def scaled_document(document: dict, factor: float) -> dict:
    for entry in document.get("benchmarks", []):
        if not str(entry.get("name", "")).startswith(SCALED_FAMILIES):
            continue
        if entry.get("aggregate_unit") == "percentage":
            continue
        for field in SCALED_FIELDS:
            if isinstance(entry.get(field), (int, float)) and not isinstance(entry.get(field), bool):
                entry[field] = entry[field] * factor
    return document


def _pairs(source: str, target: str) -> list[tuple[str, str]]:
    if os.path.isdir(source):
        names = sorted(name for name in os.listdir(source) if name.startswith("run-") and name.endswith(".json"))
        if not names:
            raise ValueError(f"{source}: a directory without run files (run-1.json ...)")
        if os.path.exists(target):
            raise ValueError(f"{target}: exists already")
        return [(os.path.join(source, name), os.path.join(target, name)) for name in names]
    if os.path.exists(target):
        raise ValueError(f"{target}: exists already")
    return [(source, target)]


def main(argv: list[str]) -> int:
    if len(argv) != 3:
        sys.stderr.write("usage: scripts/scale_times.py FACTOR INPUT OUTPUT\n")
        return 2
    try:
        factor = float(argv[0])
        if not (math.isfinite(factor) and factor > 0):
            raise ValueError(f"FACTOR {argv[0]}: give a positive number")
        pairs = _pairs(argv[1], argv[2])
        documents = []
        for source, _ in pairs:
            with open(source) as stream:
                documents.append(scaled_document(json.load(stream), factor))
    except (OSError, ValueError) as error:
        sys.stderr.write(f"scale_times: {error}\n")
        return 2
    if os.path.isdir(argv[1]):
        os.makedirs(argv[2])
    for (_, target), document in zip(pairs, documents):
        with open(target, "w") as stream:
            json.dump(document, stream, indent=1)
            stream.write("\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
