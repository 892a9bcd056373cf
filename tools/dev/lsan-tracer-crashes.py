#!/usr/bin/env python3
"""Exit 0 when every test the last ctest run failed failed only because LeakSanitizer's tracer
crashed, so that tools/dev/test-sanitized.sh may rerun them once; exit 1 otherwise.

  tools/dev/lsan-tracer-crashes.py BUILD_DIR

LeakSanitizer stops every thread with ptrace for its exit-time check, and now and then its tracer
thread crashes ("Tracer caught signal 11 ... LeakSanitizer has encountered a fatal error",
google/sanitizers#1353): the process fails having found nothing. Our mains check for leaks before
returning (tools/common/leak_check.h), which avoids the known trigger; this is the second line. A
failed test qualifies only when its output holds the tracer's crash; its rerun must then pass.
"""
import pathlib
import re
import sys

SIGNATURE = re.compile(r"Tracer caught signal \d+.*\n.*LeakSanitizer has encountered a fatal error")


def main() -> int:
    temporary = pathlib.Path(sys.argv[1]) / "Testing" / "Temporary"
    try:
        failed = [line.split(":", 1)[1].strip()
                  for line in (temporary / "LastTestsFailed.log").read_text().splitlines() if ":" in line]
        log = (temporary / "LastTest.log").read_text(errors="replace")
    except OSError as e:
        print(f"lsan-tracer-crashes: {e}", file=sys.stderr)
        return 1
    if not failed:
        return 1
    # LastTest.log: one section per test, from "N/M Test: NAME" to its "end time" line.
    sections = {}
    for m in re.finditer(r"^\d+/\d+ Test: (.+)$(.*?)^\"\1\" end time", log, re.M | re.S):
        sections[m.group(1)] = m.group(2)
    for name in failed:
        if not SIGNATURE.search(sections.get(name, "")):
            print(f"lsan-tracer-crashes: {name} failed for another reason", file=sys.stderr)
            return 1
    print("lsan-tracer-crashes: LeakSanitizer's tracer crashed in " + ", ".join(failed) +
          " (google/sanitizers#1353, no leak found); rerunning them once", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
