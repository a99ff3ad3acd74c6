"""What `lockstep run` derived, read from its file where the file holds it (derived_reader.py) rather than derived
again here: the layouts' traits and order, the comparisons it planned, the medians per pace mode, the rankings,
the model's constants; and a verify trajectory's exact solution. A file written before each (every fixture) reads
as before: the goldens (test_golden.py) hold that. Here each field is added to a fixture and must win, and a
malformed one is exit 2 with one line naming its JSON path."""
import json
import os
import unittest

from support import Scratch, fixture, run_tool
from lockstep_reports.analysis.normalisation import rank_tables
from lockstep_reports.analysis.run_analysis import layout_facts, mode_medians, sharing_layout
from lockstep_reports.common.names import parse_name
from lockstep_reports.read.inputs import load_any, load_run_file
from lockstep_reports.report import matrix, paper


def document(name: str) -> dict:
    with open(fixture(name), encoding="utf-8") as stream:
        return json.load(stream)


def layouts(*facts) -> list[dict]:
    return [{"name": name, "kind": kind, "writer_isolation": isolation} for name, kind, isolation in facts]


class Layouts(Scratch):
    """lockstep_layouts: the registry's order and traits. The names here are the fixture's; the traits decide."""

    def test_the_files_order_is_the_heat_maps_columns(self):
        raw = document("machine_a.json")
        raw["lockstep_layouts"] = layouts(("per_thread", "private_copy", 64), ("padded128", "shared", 128),
                                          ("packed", "shared", 0))
        run_file = load_run_file(self.write("a.json", raw))
        self.assertEqual(matrix.syncs_layouts(run_file)[1], ["per_thread", "padded128", "packed"])

    def test_which_layout_shares_lines_is_its_trait_not_its_name(self):
        raw = document("machine_a.json")
        raw["lockstep_layouts"] = layouts(("packed", "shared", 128), ("padded128", "shared", 0),
                                          ("per_thread", "private_copy", 64))
        run_file = load_run_file(self.write("a.json", raw))
        self.assertEqual(sharing_layout(run_file), "padded128")
        kinds = {row.kind for row in matrix.penalty_rows(run_file) if row.kind.startswith("false sharing")}
        self.assertEqual(kinds, {"false sharing: padded128 / packed"})

    def test_a_file_without_them_reads_the_registry_as_it_was(self):
        run_file = load_run_file(fixture("machine_a.json"))
        self.assertIsNone(run_file.layouts)
        self.assertEqual([facts.name for facts in layout_facts(run_file)][:1], [sharing_layout(run_file)])
        kinds = {row.kind for row in matrix.penalty_rows(run_file) if row.kind.startswith("false sharing")}
        self.assertEqual(kinds, {"false sharing: packed / padded128"})


class PlannedPairs(Scratch):
    """lockstep_planned_pairs: the run's plan. A planned comparison without a pair is drawn from the medians;
    nothing is planned again here."""

    def test_only_the_planned_and_unmeasured_comparisons_come_from_the_medians(self):
        raw = document("paced_a.json")
        a = "rk4/sync:seqlock/layout:packed/pin:compact/threads:2"
        b = "rk4/sync:seqlock/layout:per_thread/pin:compact/threads:2"
        measured = raw["lockstep_pairs"][0]
        raw["lockstep_planned_pairs"] = [
            {"comparison": measured["comparison"], "group": measured["group"], "a": measured["a"], "b": measured["b"]},
            {"comparison": "false_sharing", "group": "sync:seqlock pin:compact threads:2", "a": a, "b": b}]
        run_file = load_run_file(self.write("a.json", raw))
        rows = matrix.penalty_rows(run_file, run_file.collapsed, {"false_sharing"})
        self.assertEqual([(row.kind, row.sync, row.threads) for row in rows],
                         [("false sharing: packed / per_thread", "seqlock", 2)])
        self.assertEqual(rows[0].verdict, None)  # a ratio of medians: no interval, no verdict

    def test_a_file_without_the_plan_plans_the_missing_kinds_again(self):
        run_file = load_run_file(fixture("paced_a.json"))
        rows = matrix.penalty_rows(run_file, run_file.collapsed, {"false_sharing"})
        self.assertTrue(rows)
        self.assertTrue(all(row.kind.startswith("migration") for row in rows))


class ModeMedians(Scratch):
    def test_the_files_medians_per_mode_are_shown(self):
        raw = document("paced_a.json")
        entry = "rk4/sync:seqlock/layout:packed/pin:compact/threads:2"
        raw["lockstep_pace"]["entry_medians"] = [
            {"entry": entry, "modes": [{"mode": 0, "median_ns": 100.0, "repetitions": 3},
                                       {"mode": 1, "median_ns": 250.0, "repetitions": 2}], "straddling": 1}]
        run_file = load_run_file(self.write("a.json", raw))
        self.assertEqual(mode_medians(run_file, parse_name(entry)), ({0: (100.0, 3), 1: (250.0, 2)}, 2.5, 1))
        other = parse_name("rk4/sync:futex_spin/layout:packed/pin:compact/threads:2")
        self.assertEqual(mode_medians(run_file, other), ({}, None, 0))  # not listed: one mode, no straddling

    def test_a_mode_the_trace_does_not_have_is_refused(self):
        raw = document("paced_a.json")
        raw["lockstep_pace"]["entry_medians"] = [
            {"entry": "rk4/serial", "modes": [{"mode": 0, "median_ns": 1.0, "repetitions": 1},
                                              {"mode": 9, "median_ns": 1.0, "repetitions": 1}], "straddling": 0}]
        status, _, err = run_tool("compare", self.write("a.json", raw), fixture("paced_b.json"))
        self.assertEqual(status, 2)
        self.assertIn("lockstep_pace.entry_medians[0].modes[1].mode: is 9", err)


class Rankings(Scratch):
    def test_the_runs_ranking_is_the_tables(self):
        raw = document("machine_a.json")
        slow = "rk4/sync:std_barrier/layout:packed/pin:compact/threads:2"
        raw["lockstep_rankings"] = [{"pin": "compact", "threads": 2, "entries": [
            {"entry": slow, "ns_per_step": 5000.0, "vs_serial": 12.5},
            {"entry": "rk4/sync:seqlock/layout:packed/pin:compact/threads:2", "ns_per_step": 6000.0,
             "vs_serial": None}]}]
        run_file = load_run_file(self.write("a.json", raw))
        tables = rank_tables([run_file])
        self.assertEqual(tables[("compact", 2)][0], [("std_barrier/packed", 5000.0, 12.5),
                                                     ("seqlock/packed", 6000.0, None)])
        self.assertEqual(tables[("compact", 4)][0], [])  # the run ranked no entry there
        self.assertTrue(rank_tables([run_file], "cpu")[("compact", 4)][0])  # CPU time: ranked here

    def test_a_file_without_it_is_ranked_here(self):
        tables = rank_tables([load_run_file(fixture("machine_a.json"))])
        ranked = tables[("compact", 2)][0]
        self.assertEqual([step for _, step, _ in ranked], sorted(step for _, step, _ in ranked))


class Model(Scratch):
    MODEL = {"c_over_m": 1000.0, "positions_0": [1.0, -1.0], "evaluations_per_step": 20,
             "roots": {"computed_rad_s": {"fast": 51.2, "slow": 19.5}, "paper_rad_s": {"fast": 51.47, "slow": 19.66},
                       "paper_implied_c_over_m": 1011.9}}

    def test_the_files_constants_are_the_papers_table(self):
        raw = document("machine_a.json")
        raw["lockstep_model"] = self.MODEL
        _, markdown = self.report(self.write("a.json", raw))
        self.assertIn("model (C/m = 1000.0 s^-2)", markdown)
        self.assertIn("| mode 1 | ±51.47j | ±51.20j | -0.27 |", markdown)
        self.assertIn("a.json: serial step / 20", markdown)

    def test_a_file_without_them_gets_the_kernels_values(self):
        values = paper.model_values([load_run_file(fixture("machine_a.json"))])
        self.assertEqual((values.c_over_m, values.evaluations_per_step), (paper.C_OVER_M, paper.EVALUATIONS_PER_STEP))
        self.assertEqual(values.roots, paper.model_roots())

    def test_a_malformed_model_is_refused_in_one_line(self):
        raw = document("machine_a.json")
        raw["lockstep_model"] = dict(self.MODEL, evaluations_per_step=0)
        status, _, err = run_tool("compare", self.write("a.json", raw), fixture("machine_b.json"))
        self.assertEqual((status, len(err.splitlines())), (2, 1))
        self.assertIn("lockstep_model.evaluations_per_step: is 0, below the least 1", err)


class MalformedSections(Scratch):
    def test_each_is_refused_in_one_line_naming_its_path(self):
        cases = (("lockstep_layouts", layouts(("packed", "shared", 0), ("packed", "shared", 64)),
                  "lockstep_layouts[1].name: repeats 'packed'"),
                 ("lockstep_layouts", layouts(("packed", "spread", 0)), "lockstep_layouts[0].kind: is 'spread'"),
                 ("lockstep_planned_pairs", [{"comparison": "false_sharing", "group": "g", "a": "/", "b": "x/y"}],
                  "lockstep_planned_pairs[0].a: is '/', not an entry's name"),
                 ("lockstep_rankings", {"pin": "compact"}, "lockstep_rankings: expected a list, not an object"))
        for key, value, problem in cases:
            with self.subTest(problem):
                raw = document("machine_a.json")
                raw[key] = value
                status, _, err = run_tool("compare", self.write("a.json", raw), fixture("machine_b.json"))
                self.assertEqual((status, len(err.splitlines())), (2, 1))
                self.assertIn(problem, err)


class VerifyExactColumns(Scratch):
    def test_the_files_exact_solution_is_the_reference(self):
        text = "t,x1,x2,exact_x1,exact_x2\n0,2,-3,2,-3\n0.001,1.9,-2.9,1.95,-2.95\n"
        verify = load_any(self.write("v.csv", text))
        reference = paper.trajectory_reference(verify)
        self.assertEqual([list(values) for values in reference], [[2.0, 1.95], [-3.0, -2.95]])
        self.assertAlmostEqual(paper.trajectory_deviation(verify, reference), 0.05)

    def test_a_file_without_them_gets_the_two_mass_solution(self):
        verify = load_any(fixture("verify_a.csv"))
        self.assertIsNone(verify.exact)
        x1, _ = paper.trajectory_reference(verify)
        self.assertEqual(list(x1), list(paper.analytic_trajectory(verify.t)[0]))

    def test_a_cut_exact_column_is_refused(self):
        path = self.write("v.csv", "t,x1,x2,exact_x1,exact_x2\n0,2,-3,2,-3\n0.001,1.9,-2.9,1.95\n")
        status, _, err = run_tool("report", path, "--out", os.path.join(self.directory.name, "out"))
        self.assertEqual(status, 2)
        self.assertIn("line 3 has 4 values, not 5", err)


if __name__ == "__main__":
    unittest.main()
