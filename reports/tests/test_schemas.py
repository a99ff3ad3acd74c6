"""docs/schemas/run.schema.json is the one check of a run file's lockstep_* sections (reports/README.md, "The schemas"):
every section of every run file kept in the repository (tests/fixtures/run/, reports/samples/, the real and hand-made
fixtures of reports/tests/fixtures/) is named by the schema and fits it strictly, as the writer's output must
(tests/reports/check_result_schemas.py holds a fresh run to the same); and those files hold every section the schema
names, so that the check is not empty. What a schema cannot say is read_document's next step
(lockstep_reports/read/run_checks.py), held by test_inputs.py and test_derived.py."""
import json
import unittest

from support import FIXTURES, REPORTS_DIR

from lockstep_reports.read import schemas

RUN_FILES = sorted([*(REPORTS_DIR.parent / "tests" / "fixtures" / "run").glob("*.json"),
                    *(REPORTS_DIR / "samples").glob("*.json"), *FIXTURES.glob("*.json")])
# The sections no kept file holds, and what holds them instead.
HELD_ELSEWHERE = {
    "lockstep_scaling": "a --scaling run: reports.schema.run's scaling shape (tests/reports/check_result_schemas.py)",
    "lockstep_answer": "the answer's name since the typed entry; the kept files hold it as lockstep_headline, and "
                       "test_inputs.ReadingTheAnswer reads one moved to it",
}
# A stand-in for what the sections sit beside: the context and the entries have their own tests.
BESIDE = {"context": {}, "benchmarks": [{"name": "rk4/serial", "run_type": "iteration", "time_unit": "ns",
                                        "real_time": 1.0, "cpu_time": 1.0}]}


def run_documents() -> dict[str, dict]:
    """The kept `lockstep run` files by name: a JSON object with a context and no kind."""
    found = {}
    for path in RUN_FILES:
        try:
            document = json.loads(path.read_text(encoding="utf-8"))
        except ValueError:
            continue  # truncated.json: cut on purpose
        if isinstance(document, dict) and "context" in document and "kind" not in document:
            found[str(path.relative_to(REPORTS_DIR.parent))] = document
    return found


def sections(document: dict) -> dict:
    return {key: value for key, value in document.items() if key.startswith(schemas.SECTION_PREFIX)}


class RunSections(unittest.TestCase):
    def test_every_section_of_every_kept_file_fits_strictly(self):
        documents = run_documents()
        self.assertGreaterEqual(len(documents), 20)
        for name, document in documents.items():
            with self.subTest(name):
                self.assertEqual(schemas.unnamed_sections(document, "run"), [])
                self.assertIsNone(schemas.problem({**BESIDE, **sections(document)}, "run", strict=True))

    def test_the_kept_files_hold_every_section_the_schema_names(self):
        named = {key for key in json.loads(schemas.schema_path("run").read_text())["properties"]
                 if key.startswith(schemas.SECTION_PREFIX)}
        held = {key for document in run_documents().values() for key in sections(document)}
        self.assertEqual(named - held, set(HELD_ELSEWHERE))
        self.assertIn("entry_medians", {key for document in run_documents().values()
                                        for key in document.get("lockstep_pace", {})})

    def test_a_section_without_its_schema_fails_the_writers_check(self):
        document = {**BESIDE, "lockstep_paces": {}}
        self.assertEqual(schemas.unnamed_sections(document, "run"), ["lockstep_paces"])
        self.assertEqual(schemas.problem(document, "run", strict=True),
                         "lockstep_paces: a section run.schema.json does not name")
        self.assertIsNone(schemas.problem(document, "run"))  # the reader ignores a later lockstep's section


if __name__ == "__main__":
    unittest.main()
