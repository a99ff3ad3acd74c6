"""Entry point of `lockstep compare` and `lockstep report` (the lockstep binary execs
/usr/bin/python3 on this file with the tool's name and every argument)."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

try:
    from lockstep_reports.main import main  # noqa: E402
except ImportError as missing:  # a machine with Python but not the report's packages (a bundle's target)
    sys.stderr.write(f"lockstep {sys.argv[1] if len(sys.argv) > 1 else 'compare'}: needs Python's {missing.name} "
                     "(Debian: python3-numpy python3-scipy python3-matplotlib python3-jinja2 "
                     "python3-jsonschema); the measuring commands do not\n")
    sys.exit(2)

if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
