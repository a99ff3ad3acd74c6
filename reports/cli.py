"""Entry point of `lockstep compare` and `lockstep report` (the lockstep binary execs
/usr/bin/python3 on this file with the tool's name and every argument)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from lockstep_reports.main import main  # noqa: E402

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
