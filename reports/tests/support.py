"""Shared helpers of the report tools' tests: fixture paths and running the tool as a user would."""
import io
import os
import pathlib
import sys
from contextlib import redirect_stderr, redirect_stdout

REPORTS_DIR = pathlib.Path(__file__).resolve().parent.parent
FIXTURES = REPORTS_DIR / "tests" / "fixtures"
if str(REPORTS_DIR) not in sys.path:
    sys.path.insert(0, str(REPORTS_DIR))

from lockstep_reports.main import main  # noqa: E402


def fixture(name: str) -> str:
    return os.fspath(FIXTURES / name)


def run_tool(*argv: str):
    """(exit status, stdout, stderr) of `lockstep <argv...>` run in this process."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(argv))
    return status, out.getvalue(), err.getvalue()
