"""Issue 36, acceptance 3: the Liu (2007) reproduction report cannot go stale.

`scripts/liu2007_report.py --check` recomputes, with exactly the report's inputs, the rows its
fast check covers (the Ch. 2 statics rows of both pair models, the static-TE table, every Ch. 3
and Ch. 4 row; `CHECKED` in the script) and compares every geardyn value and verdict cell with
the printed `docs/validation/liu-2007.md`, character for character. It must pass on the
committed report and fail on a scratch copy where one printed number is changed (both in one
run: the rows are computed once and compared with each report).
"""

import re
import subprocess
import sys

DOC = "docs/validation/liu-2007.md"


def test_report_matches_recomputed_rows_and_detects_a_changed_number(repo_root, tmp_path,
                                                                    geardyn_bin):
    printed = (repo_root / DOC).read_text()
    # One number of the static-TE table (a row the check covers): the first value of the
    # 100 N·m line, raised by one in its last printed digit.
    line = next(l for l in printed.splitlines() if l.startswith("| 100 | "))
    value = re.search(r"\| 100 \| ([0-9]+\.[0-9]{2}) ", line).group(1)
    changed = f"{float(value) + 0.01:.2f}"
    scratch = tmp_path / "liu-2007.md"
    scratch.write_text(printed.replace(line, line.replace(f"| 100 | {value} ", f"| 100 | {changed} ", 1)))
    assert scratch.read_text() != printed

    proc = subprocess.run(
        [sys.executable, str(repo_root / "scripts" / "liu2007_report.py"), "--check",
         "--report", str(repo_root / DOC), "--report", str(scratch)],
        capture_output=True, text=True, cwd=repo_root)
    print(proc.stderr)
    ok = re.search(r"; 0 differ from " + re.escape(str(repo_root / DOC)), proc.stderr)
    assert ok, f"the committed report is stale:\n{proc.stderr}"
    bad = re.search(r"; ([0-9]+) differ from " + re.escape(str(scratch)), proc.stderr)
    assert bad and int(bad.group(1)) >= 1, proc.stderr
    assert "static-TE table differs" in proc.stderr
    assert proc.returncode == 1
