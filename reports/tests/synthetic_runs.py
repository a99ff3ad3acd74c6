"""Seeded synthetic `lockstep run` files for compare's tests of power and specificity: a matrix of rk4 entries
(primitives x layouts x placements x thread counts), 5 repetitions each, every repetition in the one pace mode,
with a known per-entry drift between the runs and a known spread within them. No timing: the same seed gives
the same bytes.

A repetition's time is base x shift x exp(drift_e + spread z), z standard normal from random.Random(seed), and
drift_e the entry's own (drawn from the contender's seed, standard deviation `drift`): the run-to-run drift that
repetitions inside one run cannot see. `collapsed` names entries written with one repetition and listed in the
file's lockstep_headline.collapsed, as lockstep run writes an entry that collapsed when oversubscribed."""
from __future__ import annotations

import math
import random

SYNCS = ("futex_spin", "mailbox", "seqlock", "spsc_queue", "std_barrier", "ck_mcs")
LAYOUTS = ("packed", "padded64", "padded128", "per_thread")
PINS = ("compact", "none")
THREADS = (2, 4)
REPETITIONS = 5


def entry_names() -> list[str]:
    return [f"rk4/sync:{sync}/layout:{layout}/pin:{pin}/threads:{threads}"
            for sync in SYNCS for layout in LAYOUTS for pin in PINS for threads in THREADS]


def matrix_document(seed: int, shift: float = 1.0, drift: float = 0.0, spread: float = 0.03,
                    collapsed: tuple[str, ...] = ()) -> dict:
    """A run file: every entry of entry_names() (base times 300 ns to 3 us by name), its repetitions' times as
    the module says, B/A = `shift` on average."""
    noise = random.Random(seed)
    base = random.Random(1)  # the same base times in every file
    benchmarks = []
    for name in entry_names():
        median = 300.0 * math.exp(base.uniform(0.0, math.log(10.0)))
        own_drift = noise.gauss(0.0, drift) if drift else 0.0
        count = 1 if name in collapsed else REPETITIONS
        for index in range(count):
            value = median * shift * math.exp(own_drift + noise.gauss(0.0, spread)) * (100.0 if count == 1 else 1.0)
            benchmarks.append({"name": name, "run_name": name, "run_type": "iteration", "repetitions": count,
                               "repetition_index": index, "threads": 1, "iterations": 40, "real_time": value,
                               "cpu_time": value, "time_unit": "ns", "ns_per_step": value,
                               "pace_c2c_ns": 30.0, "pace_serial_ns": 20.0, "pace_mode": 0})
    document = {
        "context": {"lockstep_schema": "2", "cpu_model": "AMD EPYC", "topology": "packages=1 l3=1 cores=2 pus=2",
                    "hypervisor": "kvm", "kernel": "6.1", "num_cpus": 2, "c2c_one_way_ns": "30.0",
                    "serial_step_ns": "20.00"},
        "benchmarks": benchmarks,
        "lockstep_pace": {
            "reference": "one-way c2c between CPUs 0 and 1; the serial RK4 step", "cpus": [0, 1],
            "readings": [{"t_s": 0.1 * index, "c2c_ns": 30.0, "serial_ns": 20.0, "mode": 0} for index in range(10)],
            "modes": [{"mode": 0, "c2c_ns": 30.0, "serial_ns": 20.0, "share": 1.0, "readings": 10}],
            "changes": 0, "summary": "c2c 30.0 ns for 100 % of the run; 0 changes"}}
    if collapsed:
        document["lockstep_headline"] = {"lines": ["The answer on this machine: synthetic"],
                                         "recommendations": [], "collapsed": list(collapsed),
                                         "false_sharing_probe": None,
                                         "false_sharing_probe_unavailable": "not measured (synthetic)",
                                         "migration_probe": None,
                                         "migration_probe_unavailable": "not measured (synthetic)"}
    return document


# The paces of paced_run_document: (c2c one-way ns, serial step ns, how much slower a step runs there).
FAST, SLOW, SLOWEST = (35.0, 26.0, 1.0), (110.0, 28.0, 2.5), (200.0, 30.0, 4.0)


def paced_run_document(seed: int, slow_share: float, shift: float = 1.0, run_drift: float = 0.03,
                       spread: float = 0.05, paces=(FAST, SLOW), repetitions: int = 6) -> dict:
    """One run of a machine that changes pace (the AMD EPYC guest's kind): each repetition in the slow pace (the
    second of `paces`; a third, where given, takes one repetition in 20) with probability slow_share, else the
    first, its time the entry's base x shift x the pace's factor x exp(the run's own drift, common to its entries
    (standard deviation run_drift) + spread z); the pace trace's readings spread by 5 % around each pace's c2c.
    slow_share 1: a run entirely in the slow pace; 0: entirely in the fast one."""
    noise = random.Random(seed)
    base = random.Random(1)
    run_shift = math.exp(noise.gauss(0.0, run_drift))
    chosen = []
    benchmarks = []
    for name in entry_names():
        median = 300.0 * math.exp(base.uniform(0.0, math.log(10.0)))
        for index in range(repetitions):
            draw = noise.random()
            pace = (2 if len(paces) > 2 and draw < 0.05 else 1 if draw < slow_share else 0)
            chosen.append(pace)
            value = median * shift * paces[pace][2] * run_shift * math.exp(noise.gauss(0.0, spread))
            benchmarks.append({"name": name, "run_name": name, "run_type": "iteration", "repetitions": repetitions,
                               "repetition_index": index, "threads": 1, "iterations": 40, "real_time": value,
                               "cpu_time": value, "time_unit": "ns", "ns_per_step": value,
                               "pace_c2c_ns": paces[pace][0], "pace_serial_ns": paces[pace][1], "pace_mode": pace})
    held = sorted(set(chosen), key=lambda pace: paces[pace][0])  # the trace lists its modes fastest first
    number = {pace: index for index, pace in enumerate(held)}
    for entry in benchmarks:
        entry["pace_mode"] = number[entry["pace_mode"]]
    readings = [{"t_s": 0.05 * index, "c2c_ns": paces[pace][0] * math.exp(noise.gauss(0.0, 0.05)),
                 "serial_ns": paces[pace][1], "mode": number[pace]} for index, pace in enumerate(chosen[::10])]
    modes = [{"mode": number[pace], "c2c_ns": paces[pace][0], "serial_ns": paces[pace][1],
              "share": chosen.count(pace) / len(chosen), "readings": sum(r["mode"] == number[pace] for r in readings)}
             for pace in held]
    return {
        "context": {"lockstep_schema": "2", "cpu_model": "AMD EPYC", "topology": "packages=1 l3=1 cores=2 pus=2",
                    "hypervisor": "kvm", "kernel": "6.1", "num_cpus": 2, "c2c_one_way_ns": "35.0",
                    "serial_step_ns": "26.00", "lockstep_matrix_s": "20.000", "lockstep_wall_s": "26.000"},
        "benchmarks": benchmarks,
        "lockstep_pace": {"reference": "one-way c2c between CPUs 0 and 1; the serial RK4 step", "cpus": [0, 1],
                          "readings": readings, "modes": modes, "changes": 0,
                          "summary": "synthetic: " + ", ".join(f"c2c {paces[p][0]:g} ns" for p in held)}}
