"""The HTML report in a real browser: headless Chromium opens a report made from
the fixtures (through the lockstep binary when --lockstep is given) and the
test checks that the page loaded, raised no script error, fetched nothing, and,
opened at #all (every section open), laid out every one of its figures at a
visible size; opened as a user opens it, that the answer comes first and only
the first sections are open. A screenshot 1400 px wide is taken too and must be
a non-empty PNG.

    /usr/bin/python3 reports/tests/browser_check.py [--lockstep build/dev/bench/lockstep] [--keep DIR]

Exit 0 when the page passes, 1 when it does not (a missing browser is a
failure, not a skip: `scripts/setup.sh --test` installs it).
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
REPORTS_DIR = os.path.dirname(HERE)
FIXTURES = os.path.join(HERE, "fixtures")
CHROMIUM = "/usr/bin/chromium"
INPUTS = [os.path.join(FIXTURES, name)
          for name in ("machine_a.json", "machine_b.json", "c2c_b.json", "delay_a.json", "verify_a.csv")]
# the pace keys (docs/pace.md) and the delay keys of --per-cpu and --find-period
PACED_INPUTS = [os.path.join(FIXTURES, name)
                for name in ("paced_every_pair.json", "delay_per_cpu.json", "delay_find_period.json")]
# a run file with the run's answer (lockstep_headline), collapsed entries and pairs measured once
HEADLINE_INPUTS = [os.path.join(FIXTURES, "headline.json")]
# The sections the page opens with (report.OPEN_SECTIONS).
OPEN_SECTIONS = "2"
SAMPLES = [os.path.join(REPORTS_DIR, "samples", name) for name in ("run.json", "c2c.json", "delay.json", "verify.csv")]


def chromium(profile: str, *arguments: str) -> subprocess.CompletedProcess:
    command = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
               "--disable-component-update", "--disable-sync", "--no-first-run", "--disable-extensions",
               "--disable-dev-shm-usage", f"--user-data-dir={profile}", "--virtual-time-budget=10000",
               *arguments]
    return subprocess.run(command, capture_output=True, text=True, timeout=240)


def make_report(inputs: list[str], out_dir: str, lockstep: str | None) -> None:
    if lockstep:
        command = [lockstep, "report", *inputs, "--out", out_dir]
    else:
        command = ["/usr/bin/python3", os.path.join(REPORTS_DIR, "cli.py"), "report", *inputs, "--out", out_dir]
    result = subprocess.run(command, capture_output=True, text=True, timeout=240)
    if result.returncode != 0:
        sys.exit(f"browser_check: `{' '.join(command)}` failed ({result.returncode}): {result.stderr.strip()}")


def attribute(dom: str, element: str, name: str) -> str | None:
    match = re.search(rf"<{element}\b[^>]*\b{name}=\"([^\"]*)\"", dom)
    return match.group(1) if match else None


def check_page(work: str, inputs: list[str], options) -> list[str]:
    """Makes a report of the inputs and opens it in Chromium; returns what went wrong."""
    failures = []
    os.makedirs(work, exist_ok=True)  # `lockstep report --out` creates the report directory, not its parents
    out_dir = os.path.join(work, "report")
    make_report(inputs, out_dir, options.lockstep)
    page = os.path.join(out_dir, "report.html")
    with open(page, encoding="utf-8") as stream:
        source = stream.read()
    expected_figures = source.count("<figure ")
    for pattern in (r"<(script|img|link|iframe)[^>]+(src|href)=\"(https?:)?//", r"@import", r"url\((https?:)?//"):
        if re.search(pattern, source):
            failures.append(f"the page refers to something outside itself ({pattern})")

    profile = os.path.join(work, "profile")
    shutil.rmtree(profile, ignore_errors=True)
    url = "file://" + os.path.abspath(page)
    as_opened = chromium(profile, "--dump-dom", url).stdout
    opened = attribute(as_opened, "body", "data-sections-open")
    if opened != OPEN_SECTIONS:
        failures.append(f"the page opens with {opened} sections open, not {OPEN_SECTIONS}")
    body = as_opened[as_opened.find("<body"):]
    if 'class="answer"' in source and body.find('class="answer"') > body.find("<details"):
        failures.append("the answer is not the first thing on the page")
    shutil.rmtree(profile, ignore_errors=True)
    dumped = chromium(profile, "--dump-dom", url + "#all")
    dom = dumped.stdout
    if dumped.returncode != 0 or "<body" not in dom:
        failures.append(f"chromium --dump-dom failed ({dumped.returncode}): {dumped.stderr.strip()[-400:]}")
    else:
        loaded = attribute(dom, "body", "data-loaded")
        errors = attribute(dom, "html", "data-errors")
        shown = attribute(dom, "body", "data-figures-shown")
        total = attribute(dom, "body", "data-figures")
        resources = attribute(dom, "body", "data-resources")
        print(f"browser_check: {os.path.basename(work)}: loaded={loaded} errors={errors} figures={total} "
              f"shown={shown} resources={resources} expected_figures={expected_figures}")
        if loaded != "yes":
            failures.append("the page's load event did not run")
        if errors != "0":
            failures.append(f"{errors} error event(s) while loading")
        if expected_figures < 5 or total != str(expected_figures) or shown != str(expected_figures):
            failures.append(f"{shown} of {total} figures laid out (the page has {expected_figures})")
        if resources != "0":
            failures.append(f"the page fetched {resources} resource(s); it must be self-contained")
    for line in dumped.stderr.splitlines():
        if "CONSOLE" in line and ("Uncaught" in line or "Error" in line):
            failures.append(f"console: {line.strip()}")

    shutil.rmtree(profile, ignore_errors=True)
    screenshot = os.path.join(work, "report.png")
    shot = chromium(profile, f"--screenshot={screenshot}", "--window-size=1400,2400", url)
    if shot.returncode != 0 or not os.path.exists(screenshot):
        failures.append(f"chromium --screenshot failed ({shot.returncode}): {shot.stderr.strip()[-400:]}")
    else:
        with open(screenshot, "rb") as stream:
            head = stream.read(8)
        if head != b"\x89PNG\r\n\x1a\n" or os.path.getsize(screenshot) < 20000:
            failures.append("the screenshot is not a PNG of a drawn page")
    shutil.rmtree(profile, ignore_errors=True)
    return failures


def main() -> int:
    parser = argparse.ArgumentParser()
    parser.add_argument("--lockstep", help="the lockstep binary (default: run reports/cli.py directly)")
    parser.add_argument("--keep", help="write the report and the screenshot here and keep them")
    options = parser.parse_args()
    if not os.access(CHROMIUM, os.X_OK):
        print(f"browser_check: {CHROMIUM} is missing: `scripts/setup.sh --test` installs Debian's chromium",
              file=sys.stderr)
        return 1

    work = options.keep or tempfile.mkdtemp(prefix="lockstep-browser-")
    os.makedirs(work, exist_ok=True)
    failures = []
    input_sets = [("fixtures", INPUTS), ("paced", PACED_INPUTS), ("headline", HEADLINE_INPUTS)]
    if all(os.path.exists(path) for path in SAMPLES):  # reports/samples/, once make_samples.sh has run
        input_sets.append(("samples", SAMPLES))
    try:
        for name, inputs in input_sets:
            failures += [f"{name}: {failure}" for failure in check_page(os.path.join(work, name), inputs, options)]
    finally:
        if not options.keep:
            shutil.rmtree(work, ignore_errors=True)

    for failure in failures:
        print(f"browser_check: FAIL: {failure}", file=sys.stderr)
    if not failures:
        print("browser_check: the report renders in headless Chromium with all its figures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
